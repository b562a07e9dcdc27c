// Synthetic ego drives along the lane graph (`icube scene route`), for maps
// that come without an ego trajectory (OpenDRIVE).
//
// Lane graph: a lane's successors are its exit_lanes (Waymo's links;
// OpenDRIVE road, lane and junction links with a geometric fallback, see
// opendrive/lane_topology.h). A lane without usable exit lanes continues
// into every lane whose first point lies within `connect_distance_m` of its
// last point with a start heading within `connect_angle_deg` of its end
// heading.
//
// Planning: every lane's reach is the longest drive from its first point
// (lane lengths plus the gaps bridged between lanes), capped at the
// requested length; a lane on a cycle of the graph can be driven round for
// ever and reaches the cap. A seeded RNG (SplitMix64, the same on every
// platform) picks the start lane, unless one is given, among the car lanes
// (any lanes on maps without them) that reach the requested length, else
// among those that reach furthest; and at every fork one of the successors
// from which the rest of the length can still be driven, else one of those
// that go furthest. So a drive stops short (at a dead end) only when no
// drive of the requested length exists from its start lane, and
// RouteReport::longest_possible_m says how long the longest one is.
//
// The output is a copy of the scene with Scene::timestamps at `rate_hz`
// (0, 0.1, 0.2, ... s), one ego pose per timestamp spaced speed/rate metres
// apart along the lane centre lines (origin on the centre line, z from the
// lane points, x forward along the smoothed 3D tangent, z up as far as the
// slope allows), a default front camera (frames.h waymo_front_camera at
// 832×480, mounted kRouteCameraMount) when the scene has none, and `missing`
// updated. Object tracks timed by the input's timestamps no longer match and
// are dropped (noted in the report).
#pragma once

#include "scene/input_error.h"
#include "scene/scene.h"

#include <glm/glm.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace icube::scene {

// Camera mount of the default route camera in the ego FLU frame (metres): over
// the bonnet, 1.8 m above the lane centre line, looking forward.
inline constexpr glm::dvec3 kRouteCameraMount{1.5, 0.0, 1.8};

struct RouteOptions {
  double length_m = 300.0;   // requested drive length (> 0)
  double speed_mps = 10.0;   // constant speed (> 0)
  uint64_t seed = 0;         // start lane and fork choices
  std::optional<int64_t> start_lane;  // Lane::id to start on (its first point)
  double rate_hz = 10.0;     // pose rate (InfiniCube records at 10 Hz)
  double connect_distance_m = 0.5;
  double connect_angle_deg = 30.0;
  double heading_smoothing_m = 1.0;  // Gaussian sigma along the path for the heading
};

struct RouteReport {
  std::vector<int64_t> lanes;  // lane ids driven, in order (a lane can repeat on loops)
  double length_m = 0.0;       // arc length from the first to the last pose
  size_t poses = 0;
  bool dead_end = false;       // stopped early: the last lane has no successor
  // The longest drive the lane graph allows from the start lane (lane lengths
  // plus the gaps bridged between lanes), capped at the requested length: below
  // it only when no drive of the requested length exists from that lane.
  double longest_possible_m = 0.0;
  std::vector<std::string> notes;  // one-line remarks for the user (dead end, dropped tracks, ...)
};

// Successors of every lane (indices into map.lanes), sorted and unique.
// Lanes with fewer than two distinct points have none and are no one's successor.
std::vector<std::vector<size_t>> lane_successors(const Map& map, const RouteOptions& options = {});

// Throws InputError (the scene's source file) when the map has no usable
// lanes or the start lane does not exist, std::invalid_argument for bad options.
Scene sample_route(const Scene& in, const RouteOptions& options = {}, RouteReport* report = nullptr);

}  // namespace icube::scene
