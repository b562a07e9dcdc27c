// Derives the engine's map layers from a sampled OpenDRIVE road
// (formats.md §2.4):
//  - road lines: every border carrying a roadMark other than none/grass/curb
//    (the centre lane's mark sits at t0), split where the mark's type or
//    colour changes, points along +s, source_type "<type> <color>";
//  - road edges: borders between a drivable lane (OpenDriveOptions::
//    drivable_lane_types) and a non-drivable lane or the road's outer side
//    -> Boundary; when the non-drivable run separates drivable lanes of
//    opposite sides (carriageways) -> Median; any border whose mark is
//    "curb" -> Curb. Lanes narrower than 1 cm at a sample are transparent;
//  - lanes: centre line (mid t of its two borders) of every driving-like
//    lane (driving, entry, exit, onRamp, offRamp, connectingRamp, slipLane ->
//    SurfaceStreet, or Freeway on a road whose <type> is "motorway";
//    biking -> BikeLane), in driving direction: right lanes along +s, left
//    lanes against it, flipped on rule="LHT" roads.
// Polylines of consecutive lane sections are joined when they meet within
// 1 cm (lane centres: 5 cm, preferring the lane named by <predecessor>).
//
// Feature ids: lanes (road_ordinal + 1)·1e8 + section·1000 + (lane id + 500),
// where road_ordinal is the road's index in document order and section the
// index of its first lane section; road lines 1e12 + k; road edges 2e12 + k.
#pragma once

#include "scene/opendrive/road_sampling.h"
#include "scene/opendrive/xodr_document.h"
#include "scene/scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace icube::scene::odr {

inline constexpr int64_t kRoadLineIdBase = 1'000'000'000'000;
inline constexpr int64_t kRoadEdgeIdBase = 2'000'000'000'000;
int64_t lane_feature_id(size_t road_ordinal, size_t section, int lane_id);

// Waymo type of a roadMark; nullopt when the mark draws no line (none, grass, curb).
std::optional<RoadLineType> road_line_type(const std::string& type, const std::string& color);
std::optional<LaneType> lane_centre_type(const std::string& lane_type, bool motorway);
bool is_drivable(const std::vector<std::string>& drivable_types, const std::string& lane_type);

// Appends b to a (without b's first point) when a.back() is within tol of b.front().
bool join_polyline(std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b, double tol);

void emit_road_lines(const Road& road, const std::vector<SectionSamples>& samples, Map& map, int64_t& next_id);
void emit_road_edges(const Road& road, const std::vector<SectionSamples>& samples,
                     const std::vector<std::string>& drivable_types, Map& map, int64_t& next_id);
// Where a lane centre line of the map lies on its road: the lane sections
// (indices into Road::sections) and OpenDRIVE lane ids of its first and last
// part in +s order, and whether it drives against +s.
struct LaneSpan {
  size_t road = 0;  // index in Document::roads
  size_t first_section = 0;
  int first_lane = 0;
  size_t last_section = 0;
  int last_lane = 0;
  bool backwards = false;
};

// Appends the road's lanes to map.lanes and one LaneSpan per lane to `spans`
// (kept parallel to map.lanes).
void emit_lanes(const Road& road, size_t road_ordinal, const std::vector<SectionSamples>& samples, Map& map,
                std::vector<LaneSpan>& spans);

// entry_lanes / exit_lanes from geometry, the fallback for lanes the map's
// topology (lane_topology.h) gave no exit: B follows A when B starts within
// 10 cm of A's end with a heading change below 60°.
void link_lanes(Map& map);
// Horizontal unit direction at a lane centre line's start or end (the first non-degenerate
// segment; zero when every segment is degenerate).
glm::dvec2 lane_end_direction(const std::vector<glm::dvec3>& pts, bool at_end);

}  // namespace icube::scene::odr
