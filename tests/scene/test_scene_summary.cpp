// Scene summaries (engine/scene/scene_summary.h) on a synthetic scene whose
// answers are known: counts by type, static/dynamic, map extent, duration,
// ego path length over valid poses, and the formatted text.
#include "scene/scene_summary.h"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

using namespace icube::scene;

namespace {

EgoPose ego_at(double x, double y, double z, bool valid = true) {
  return {glm::translate(glm::dmat4(1.0), glm::dvec3(x, y, z)), valid};
}

Track track(int64_t id, ObjectType type, bool dynamic) {
  Track t;
  t.id = id;
  t.type = type;
  t.dynamic = dynamic;
  t.states.assign(4, BoxState{});
  t.states[1].valid = t.states[2].valid = true;
  return t;
}

Scene synthetic_scene() {
  Scene s;
  s.provenance = {"clip.tfrecord", "waymo-scenario", "abc123", ""};
  s.prompt = "sunny suburb";
  s.timestamps = {10.0, 10.1, 10.2, 10.5};
  s.current_time_index = 1;
  Map& m = s.map;
  m.road_edges.push_back({1, RoadEdgeType::Boundary, {{0, 0, 0}, {10, 0, 0}}});
  m.road_edges.push_back({2, RoadEdgeType::Boundary, {{0, 5, 1}}});
  m.road_edges.push_back({3, RoadEdgeType::Median, {{-3, 2, 0}, {1, 1, 0}}});
  m.road_lines.push_back({4, RoadLineType::SolidDoubleYellow, "", {{2, 2, 0}, {3, 2, 0}}});
  m.road_lines.push_back({5, static_cast<RoadLineType>(42), "", {{2, 3, 0}}});  // out of range -> unknown
  Lane lane;
  lane.id = 6;
  lane.type = LaneType::Freeway;
  lane.points = {{0, 1, 0}, {20, 1, 2}};
  m.lanes.push_back(lane);
  m.crosswalks.push_back({7, {{5, 5, 0}, {6, 5, 0}, {6, 6, 0}}});
  m.speed_bumps.push_back({8, {{1, 1, -4}}});
  m.stop_signs.push_back({9, {4, 30, 0}, {6}});
  s.tracks = {track(10, ObjectType::Vehicle, true), track(11, ObjectType::Vehicle, false),
              track(12, ObjectType::Pedestrian, true), track(13, ObjectType::Cyclist, false),
              track(14, ObjectType::Vehicle, false)};
  s.sdc_track_index = 0;
  // Valid positions (0,0,0) -> (3,4,0) -> [invalid (100,100,100)] -> (3,4,12): 5 + 12 = 17 m.
  s.ego = {ego_at(0, 0, 0), ego_at(3, 4, 0), ego_at(100, 100, 100, false), ego_at(3, 4, 12)};
  s.cameras.push_back(Camera{});
  s.missing = {"cameras intrinsics", "lidar"};
  return s;
}

}  // namespace

TEST_CASE("scene_summary: counts map features by type") {
  const SceneSummary s = summarize(synthetic_scene());
  CHECK(s.road_edges == 3);
  CHECK(s.road_edges_by_type == std::array<size_t, 4>{0, 2, 1, 0});
  CHECK(s.road_lines == 2);
  CHECK(s.road_lines_by_type[size_t(RoadLineType::SolidDoubleYellow)] == 1);
  CHECK(s.road_lines_by_type[0] == 1);  // the out-of-range type
  CHECK(s.lanes_by_type == std::array<size_t, 4>{0, 1, 0, 0});
  CHECK(s.crosswalks == 1);
  CHECK(s.driveways == 0);
  CHECK(s.speed_bumps == 1);
  CHECK(s.stop_signs == 1);
  CHECK(s.map_points == 2 + 1 + 2 + 2 + 1 + 2 + 3 + 1 + 1);
}

TEST_CASE("scene_summary: map extent covers every map point including stop signs") {
  const SceneSummary s = summarize(synthetic_scene());
  REQUIRE(s.has_map_extent);
  CHECK(s.map_min == glm::dvec3(-3, 0, -4));
  CHECK(s.map_max == glm::dvec3(20, 30, 2));
  const SceneSummary empty = summarize(Scene{});
  CHECK_FALSE(empty.has_map_extent);
  CHECK(empty.map_points == 0);
}

TEST_CASE("scene_summary: counts tracks by type and static/dynamic") {
  const SceneSummary s = summarize(synthetic_scene());
  CHECK(s.tracks == 5);
  CHECK(s.tracks_by_type == std::array<size_t, 6>{0, 3, 1, 1, 0, 0});
  CHECK(s.dynamic_by_type == std::array<size_t, 6>{0, 1, 1, 0, 0, 0});
  CHECK(s.static_tracks == 3);
  CHECK(s.dynamic_tracks == 2);
  CHECK(s.box_states == 20);
  CHECK(s.valid_box_states == 10);
  CHECK(s.sdc_track_index == 0);
}

TEST_CASE("scene_summary: duration and ego path length skip invalid poses") {
  const SceneSummary s = summarize(synthetic_scene());
  CHECK(s.timestamps == 4);
  CHECK(s.duration == doctest::Approx(0.5).epsilon(1e-15));
  CHECK(s.current_time_index == 1);
  CHECK(s.ego_poses == 4);
  CHECK(s.valid_ego_poses == 3);
  CHECK(s.ego_path_length == 17.0);
  Scene one;
  one.timestamps = {3.0};
  one.ego = {ego_at(1, 2, 3)};
  const SceneSummary o = summarize(one);
  CHECK(o.duration == 0.0);
  CHECK(o.ego_path_length == 0.0);
}

TEST_CASE("scene_summary: format_summary prints every part") {
  const std::string text = format_summary(summarize(synthetic_scene()));
  CHECK(text ==
        "source: clip.tfrecord (waymo-scenario), scenario abc123\n"
        "time: 4 timestamps over 0.500 s, current index 1\n"
        "map: 15 points, x [-3.000, 20.000] y [0.000, 30.000] z [-4.000, 2.000] m\n"
        "  road edges: 3 (boundary 2, median 1)\n"
        "  road lines: 2 (unknown 1, solid_double_yellow 1)\n"
        "  lanes: 1 (freeway 1)\n"
        "  crosswalks: 1, driveways: 0, speed bumps: 1, stop signs: 1\n"
        "tracks: 5 (vehicle 3, pedestrian 1, cyclist 1); static 3, dynamic 2; ego = track 0\n"
        "  boxes: 20 states, 10 valid\n"
        "ego: 4 poses (3 valid), path length 17.000 m\n"
        "cameras: 1 (front)\n"
        "missing: cameras intrinsics, lidar\n"
        "prompt: sunny suburb\n");
}

TEST_CASE("scene_summary: format_summary of an OpenDRIVE-like static map") {
  Scene s;
  s.provenance = {"Town01.xodr", "opendrive", "Town01", "OpenDRIVE 1.4"};
  s.map.geo_reference = "+proj=tmerc +lat_0=0";
  s.map.road_lines.push_back({1, RoadLineType::BrokenSingleWhite, "broken white", {{0, 0, 0}, {1, 0, 0}}});
  s.missing = {"ego trajectory", "object boxes", "cameras"};
  CHECK(format_summary(summarize(s)) ==
        "source: Town01.xodr (opendrive, OpenDRIVE 1.4), scenario Town01\n"
        "time: none (static scene)\n"
        "map: 2 points, x [0.000, 1.000] y [0.000, 0.000] z [0.000, 0.000] m\n"
        "  road edges: 0\n"
        "  road lines: 1 (broken_single_white 1)\n"
        "  lanes: 0\n"
        "  crosswalks: 0, driveways: 0, speed bumps: 0, stop signs: 0\n"
        "  geo reference: +proj=tmerc +lat_0=0\n"
        "tracks: 0; static 0, dynamic 0\n"
        "ego: none\n"
        "cameras: 0\n"
        "missing: ego trajectory, object boxes, cameras\n");
}
