// Teleport targets for the viewer (CPU only; library icube_viewer_core):
// the ego track start, the scene's map features (lanes, crosswalks, stop
// signs, speed bumps, driveways) and the world's chunks (51.2 m tiles of the
// world's x-y plane holding drivable ground), and placing the car there.
//
// Placing: the car goes to the target's x, y; the ground is found by a
// downward column walk (ground_height, vehicle.h) from `above` metres over the
// target's z (map features; their z is on the road) or from the top of the
// world (chunks; the column that is searched is the nearest one to the tile
// centre whose first solid voxel from the top is road / lane marking, else
// other ground). The heading is the target's (ego start, lanes: the centre
// line's direction there), else the direction of the nearest lane centre line
// within `lane_radius` metres, else the car's current heading.
// Tests: tests/viewer/test_viewer_teleport.cpp.
#pragma once

#include "scene/scene.h"
#include "vehicle.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <optional>
#include <string>
#include <vector>

namespace icube::viewer {

enum class TargetKind { EgoStart, Lane, Crosswalk, StopSign, SpeedBump, Driveway, Chunk };
const char* target_kind_name(TargetKind k);

struct TeleportTarget {
  TargetKind kind = TargetKind::Chunk;
  std::string label;           // "lane 12 (surface street)", "chunk (3, -1)", ...
  glm::dvec3 position{0.0};    // world; chunks: tile centre at the top of the world
  std::optional<double> yaw;   // heading to face, when the target has one
};

// The ego track start (first valid ego pose) and every map feature, in this
// order: ego, lanes, crosswalks, stop signs, speed bumps, driveways.
std::vector<TeleportTarget> map_targets(const scene::Scene& s);

// One target per tile_m x tile_m tile (tile (i, j) = [i·tile_m, (i+1)·tile_m) x ..., world metres)
// that holds drivable ground (classes curb..sidewalk), sorted by (j, i).
std::vector<TeleportTarget> chunk_targets(const world::VoxelGrid& grid, double tile_m = 51.2);

// Heading of the nearest lane centre-line segment within max_dist of xy (x-y distance).
std::optional<double> nearest_lane_heading(const scene::Scene& s, const glm::dvec2& xy, double max_dist);

struct PlaceOptions {
  double above = 3.0;         // map features: search the ground from z + above downwards
  double lane_radius = 12.0;  // m: heading from the nearest lane within this distance
  double search_radius = 26.0;  // chunks: columns searched around the tile centre, m (half a tile)
};

// Puts the car on the ground at the target (see above), speed 0. False (car
// unchanged) when no ground is found there.
bool place_at_target(VehicleState& car, const TeleportTarget& t, const world::VoxelGrid& grid,
                     const VehicleLimits& lim, const GroundOptions& ground, const scene::Scene* s,
                     const PlaceOptions& opts = {});

}  // namespace icube::viewer
