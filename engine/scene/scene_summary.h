// What a scene holds, in numbers: feature and track counts by type, map
// extents, time span, ego path length, and what the source could not give.
// Used by `icube scene info` and by tests that check readers.
#pragma once

#include "scene/scene.h"

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace icube::scene {

struct SceneSummary {
  Provenance provenance;
  std::string prompt;

  // Map: counts indexed by the enum's value (out-of-range values count as 0 = unknown).
  std::array<size_t, 4> road_edges_by_type{};  // RoadEdgeType
  std::array<size_t, 9> road_lines_by_type{};  // RoadLineType
  std::array<size_t, 4> lanes_by_type{};       // LaneType
  size_t road_edges = 0, road_lines = 0, lanes = 0;
  size_t crosswalks = 0, driveways = 0, speed_bumps = 0, stop_signs = 0;
  std::string geo_reference;
  size_t map_points = 0;        // every polyline/polygon vertex plus one per stop sign
  bool has_map_extent = false;  // false when the map has no points
  glm::dvec3 map_min{0.0}, map_max{0.0};

  // Tracks, indexed by ObjectType.
  std::array<size_t, 6> tracks_by_type{};
  std::array<size_t, 6> dynamic_by_type{};
  size_t tracks = 0, static_tracks = 0, dynamic_tracks = 0;
  size_t box_states = 0, valid_box_states = 0;
  int sdc_track_index = -1;

  // Time.
  size_t timestamps = 0;
  double duration = 0.0;  // last − first timestamp (s); 0 with fewer than two
  int current_time_index = 0;

  // Ego: path length = sum of distances between successive valid ego positions
  // (invalid poses are skipped, not treated as breaks).
  size_t ego_poses = 0, valid_ego_poses = 0;
  double ego_path_length = 0.0;

  std::vector<std::string> camera_names;
  std::vector<std::string> missing;
};

SceneSummary summarize(const Scene& scene);

// Human-readable, several lines, each ending in '\n'. Zero counts of a type are left out.
std::string format_summary(const SceneSummary& summary);

}  // namespace icube::scene
