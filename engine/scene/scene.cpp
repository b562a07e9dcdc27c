#include "scene/scene.h"

#include <algorithm>
#include <numeric>

namespace icube::scene {

bool is_ego_track(const Scene& scene, size_t track_index) {
  return scene.sdc_track_index >= 0 && static_cast<size_t>(scene.sdc_track_index) == track_index;
}

bool tracks_unclassified(const Scene& scene) {
  for (size_t i = 0; i < scene.tracks.size(); ++i)
    if (scene.tracks[i].type == ObjectType::Vehicle && scene.tracks[i].instance_id == 0 && !is_ego_track(scene, i))
      return true;
  return false;
}

const BoxState* state_filled(const Track& t, int time_index, size_t* source) {
  const size_t n = t.states.size();
  if (n == 0 || time_index < 0) return nullptr;
  const size_t at = std::min(static_cast<size_t>(time_index), n - 1);
  size_t pick = n;
  if (static_cast<size_t>(time_index) < n && t.states[at].valid) pick = at;
  for (size_t k = static_cast<size_t>(time_index) + 1; pick == n && k < n; ++k)
    if (t.states[k].valid) pick = k;
  for (size_t k = std::min(at + 1, n); pick == n && k-- > 0;)
    if (t.states[k].valid) pick = k;
  if (pick == n) return nullptr;
  if (source) *source = pick;
  return &t.states[pick];
}

bool state_moving(const Track& t, size_t i) {
  if (i == 0 || i >= t.states.size() || !t.states[i].valid || !t.states[i - 1].valid) return false;
  return glm::length(t.states[i].center - t.states[i - 1].center) > kMovingThresholdMetres;
}

void classify_tracks(Scene& scene, double moving_threshold) {
  std::vector<size_t> order(scene.tracks.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return scene.tracks[a].id < scene.tracks[b].id; });
  uint32_t next_static = kFirstStaticInstanceId, next_dynamic = kFirstDynamicInstanceId;
  for (size_t i : order) {
    Track& t = scene.tracks[i];
    t.dynamic = false;
    if (is_ego_track(scene, i)) {
      t.instance_id = 0;
      continue;
    }
    const BoxState* prev = nullptr;
    for (const BoxState& s : t.states) {
      if (!s.valid) continue;
      if (prev && glm::length(s.center - prev->center) > moving_threshold) t.dynamic = true;
      prev = &s;
    }
    t.instance_id = t.dynamic ? next_dynamic++ : next_static++;
  }
}

const char* object_type_name(ObjectType t) {
  switch (t) {
    case ObjectType::Vehicle: return "vehicle";
    case ObjectType::Pedestrian: return "pedestrian";
    case ObjectType::Cyclist: return "cyclist";
    case ObjectType::Sign: return "sign";
    case ObjectType::Other: return "other";
    default: return "unset";
  }
}

const char* road_edge_type_name(RoadEdgeType t) {
  switch (t) {
    case RoadEdgeType::Boundary: return "boundary";
    case RoadEdgeType::Median: return "median";
    case RoadEdgeType::Curb: return "curb";
    default: return "unknown";
  }
}

const char* road_line_type_name(RoadLineType t) {
  switch (t) {
    case RoadLineType::BrokenSingleWhite: return "broken_single_white";
    case RoadLineType::SolidSingleWhite: return "solid_single_white";
    case RoadLineType::SolidDoubleWhite: return "solid_double_white";
    case RoadLineType::BrokenSingleYellow: return "broken_single_yellow";
    case RoadLineType::BrokenDoubleYellow: return "broken_double_yellow";
    case RoadLineType::SolidSingleYellow: return "solid_single_yellow";
    case RoadLineType::SolidDoubleYellow: return "solid_double_yellow";
    case RoadLineType::PassingDoubleYellow: return "passing_double_yellow";
    default: return "unknown";
  }
}

const char* lane_type_name(LaneType t) {
  switch (t) {
    case LaneType::Freeway: return "freeway";
    case LaneType::SurfaceStreet: return "surface_street";
    case LaneType::BikeLane: return "bike_lane";
    default: return "undefined";
  }
}

}  // namespace icube::scene
