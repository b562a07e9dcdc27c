#include "scene/scene.h"

#include <algorithm>
#include <numeric>

namespace icube::scene {

void classify_tracks(Scene& scene, double moving_threshold) {
  std::vector<size_t> order(scene.tracks.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return scene.tracks[a].id < scene.tracks[b].id; });
  uint32_t next_static = kFirstStaticInstanceId, next_dynamic = kFirstDynamicInstanceId;
  for (size_t i : order) {
    Track& t = scene.tracks[i];
    t.dynamic = false;
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
