// Object states as InfiniCube distributes them over frames (engine/scene/scene.h):
// state_filled (nearest later valid state, else nearest earlier), state_moving
// (per-frame object_is_moving), and classify_tracks leaving the ego out of the
// instance ids.
#include <doctest/doctest.h>

#include "scene/scene.h"

#include <vector>

using namespace icube::scene;

namespace {

// A vehicle track over `n` time indices, valid where `valid[i]`, centre x = i.
Track track(int64_t id, const std::vector<bool>& valid, double step = 1.0) {
  Track t;
  t.id = id;
  t.type = ObjectType::Vehicle;
  for (size_t i = 0; i < valid.size(); ++i) {
    BoxState b;
    b.center = {step * static_cast<double>(i), 0.0, 0.0};
    b.length = 4.0;
    b.width = 2.0;
    b.height = 1.5;
    b.valid = valid[i];
    t.states.push_back(b);
  }
  return t;
}

// Index of the state state_filled returns, -1 for none.
int filled(const Track& t, int time_index) {
  size_t src = 999;
  const BoxState* b = state_filled(t, time_index, &src);
  if (!b) return -1;
  CHECK(b == &t.states[src]);
  return static_cast<int>(src);
}

}  // namespace

TEST_CASE("object states: state_filled takes the nearest later valid state, else the nearest earlier one") {
  //                      0      1     2      3      4     5      6
  const Track t = track(7, {false, true, false, false, true, false, false});
  CHECK(filled(t, 0) == 1);  // before the first appearance: the first state (backward pass)
  CHECK(filled(t, 1) == 1);
  CHECK(filled(t, 2) == 4);  // a gap: the next later state (the backward pass runs first)
  CHECK(filled(t, 3) == 4);
  CHECK(filled(t, 4) == 4);
  CHECK(filled(t, 5) == 4);  // after the last appearance: the last state (forward pass)
  CHECK(filled(t, 6) == 4);
  CHECK(filled(t, 50) == 4);  // past the end of the scene
  CHECK(filled(t, -1) == -1);  // no time index
  CHECK(filled(track(8, {false, false}), 1) == -1);
  CHECK(filled(track(9, {}), 0) == -1);
}

TEST_CASE("object states: object_is_moving compares with the previous time index only") {
  const Track t = track(1, {true, true, false, true, true}, 0.06);
  CHECK(!state_moving(t, 0));  // no previous state
  CHECK(state_moving(t, 1));   // 0.06 m > 0.05 m
  CHECK(!state_moving(t, 2));  // invalid
  CHECK(!state_moving(t, 3));  // previous index invalid
  CHECK(state_moving(t, 4));
  CHECK(!state_moving(t, 9));
  CHECK(!state_moving(track(2, {true, true}, 0.05), 1));  // exactly the threshold is not moving
}

TEST_CASE("object states: classify_tracks gives the ego no instance id; dynamic ids start at 10000") {
  Scene s;
  s.tracks.push_back(track(30, {true, true, true}, 1.0));  // moving
  s.tracks.push_back(track(5, {true, true, true}, 0.0));   // parked
  s.tracks.push_back(track(1, {true, true, true}, 2.0));   // the ego: lowest id, moving
  s.tracks.push_back(track(20, {true, false, true}, 1.0));  // moving across a gap
  s.sdc_track_index = 2;
  CHECK(tracks_unclassified(s));
  classify_tracks(s);
  CHECK(!tracks_unclassified(s));
  CHECK(is_ego_track(s, 2));
  CHECK(!is_ego_track(s, 0));
  CHECK(s.tracks[2].instance_id == 0);
  CHECK(!s.tracks[2].dynamic);
  CHECK(s.tracks[1].instance_id == kFirstStaticInstanceId);
  CHECK(!s.tracks[1].dynamic);
  CHECK(s.tracks[3].instance_id == kFirstDynamicInstanceId);  // id 20 before id 30
  CHECK(s.tracks[0].instance_id == kFirstDynamicInstanceId + 1);
  CHECK(s.tracks[0].dynamic);
  Scene no_ego = s;
  no_ego.sdc_track_index = -1;
  classify_tracks(no_ego);
  CHECK(no_ego.tracks[2].instance_id == kFirstDynamicInstanceId);  // without an ego index it is an object
}
