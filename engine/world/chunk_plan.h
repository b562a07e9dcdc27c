// Which Stage-1 chunks a scene needs, and where each one sits (conventions
// §1, §9.3). Two modes, as InfiniCube's outpainting has:
//
// Trajectory mode (plan_trajectory): key poses every `stride_m` (38.4 m) of
// ego travel, measured as 3D arc length along the valid ego positions; the
// first key is the first valid pose. A key that falls between two poses is
// interpolated (position linearly, rotation by slerp), so keys are exactly
// `stride_m` apart along the path. After the last key on the path,
// `extrapolate_chunks` more keys continue the arc-length sequence straight
// along the last valid pose's forward axis (its rotation kept). The key
// camera is the scene's first camera (camera_to_world_flu, frames.h) or, when
// the scene has none, the ego pose raised `default_camera_height_m`; the
// chunk frame has that camera's FLU axes and its origin kChunkUpOffset (6.4 m)
// along the camera's up axis (ChunkPose). (InfiniCube also keys the last
// frame; here the keys keep the exact 38.4 m spacing past the end instead.)
//   - fewer than 2 valid ego poses: InputError ("needs an ego trajectory").
//   - a parked ego (total travel < parked_travel_m): one chunk at the first
//     valid pose and no extrapolation (there is no direction of travel).
//
// Blocks mode (plan_blocks): a translation-only lattice in world axes with
// stride `stride_m`, anchored so that the first block's 51.2 m footprint
// starts at the minimum x and y of the map's road edges, road lines and lane
// centre lines (InfiniCube's "shift min to 0, centres from 25.6 m"); this
// anchor moves with the map, so a shifted map gives the same plan shifted.
// A block is kept when its footprint [c - 25.6, c + 25.6) in x and y holds at
// least one road-edge point and one road-surface point: RoadSurface::points()
// of the fitted road surface (road_surface.h, conventions §6; fitted here
// with default options unless a precomputed surface is passed). Only blocks
// that contain map points are visited (points are binned
// into the at most 2 x 2 blocks whose footprints hold them), never the whole
// lattice over the bounding box. Order: x outer, y inner. The block's z: the
// median z of the road-edge, road-line and lane vertices in its footprint is
// taken as the road height; a virtual key camera sits `default_camera_height_m`
// (1.5 m) above it and the chunk centre 6.4 m above that camera, exactly as a
// trajectory chunk keyed on a camera 1.5 m above the road would be.
#pragma once

#include "scene/scene.h"
#include "world/chunk_pose.h"
#include "world/road_surface.h"

#include <glm/glm.hpp>

#include <string>
#include <vector>

namespace icube::world {

enum class PlanMode { Trajectory, Blocks };
enum class ChunkKind { Key, Extrapolated, Block };

const char* plan_mode_name(PlanMode m);
const char* chunk_kind_name(ChunkKind k);

struct PlanOptions {
  double stride_m = kChunkStride;
  int extrapolate_chunks = 1;            // trajectory mode: keys past the end (>= 0)
  double default_camera_height_m = 1.5;  // camera above the ego (no camera) / above the road (blocks)
  double parked_travel_m = 0.5;          // trajectory mode: less total travel = parked
  int max_chunks = 0;                    // plan_chunks: only the first this many chunks of the plan (0 = all)
};

// Per chunk, beside its ChunkPose.
struct ChunkInfo {
  ChunkKind kind = ChunkKind::Key;
  double arc_length_m = 0.0;     // trajectory: ego travel at the key (extrapolated: continued)
  glm::dvec3 ego_position{0.0};  // trajectory: the key's ego position; blocks: the block centre at road height
  int time_index = -1;           // trajectory: the valid pose at or before the key; -1 otherwise
  int lattice_i = 0, lattice_j = 0;  // blocks: lattice indices from the anchor
  size_t edge_points = 0, surface_points = 0;  // blocks: road-edge vertices, road-surface points in the footprint
};

struct ChunkPlan {
  PlanMode mode = PlanMode::Trajectory;
  double stride_m = kChunkStride;
  std::vector<ChunkPose> chunks;
  std::vector<ChunkInfo> info;  // same size and order as chunks
  double path_length_m = 0.0;   // trajectory: ego travel
  bool parked = false;          // trajectory: the ego did not move
  glm::dvec2 lattice_anchor{0.0};  // blocks: min x, y of the map points (first footprint's corner)
  std::vector<std::string> notes;  // one-line remarks for the user
};

// Throws scene::InputError (naming the scene's source file) when the scene
// cannot be planned, std::invalid_argument for bad options.
ChunkPlan plan_trajectory(const scene::Scene& scene, const PlanOptions& options = {});
ChunkPlan plan_blocks(const scene::Scene& scene, const PlanOptions& options = {});
// Blocks mode with a road surface already fitted to scene.map (one fit per scene).
ChunkPlan plan_blocks(const scene::Scene& scene, const RoadSurface& surface, const PlanOptions& options = {});
// Either mode; with options.max_chunks the plan's first that many chunks (and a note saying so).
ChunkPlan plan_chunks(const scene::Scene& scene, PlanMode mode, const PlanOptions& options = {});

// Chunk centre (translation of chunk_to_world) and heading (yaw of the chunk x axis, radians).
glm::dvec3 chunk_centre(const ChunkPose& c);
double chunk_heading(const ChunkPose& c);
// The footprint's 4 corners in world x, y (chunk x, y = ±25.6 at chunk z = 0), counter-clockwise.
std::vector<glm::dvec2> chunk_footprint(const ChunkPose& c);

// The plan as JSON ("icube-chunk-plan", version 1): mode, stride, and per
// chunk index, kind, chunk_to_world (4 rows of 4), key camera, centre, heading.
std::string plan_to_json(const ChunkPlan& plan);

}  // namespace icube::world
