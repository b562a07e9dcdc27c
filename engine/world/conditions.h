// Stage-1 condition volume for one chunk (conventions §7), CPU reference.
//
// Channels, in the UNet's input order without the 8 latent channels:
//   0-2  i, j, k       raw latent ijk in [-32, 31] as float (not normalised)
//   3    road_edge     binary occupancy of road-edge points (0.25 m resampled)
//   4    road_line     binary occupancy of road-line points (0.25 m resampled)
//   5    road_surface  binary occupancy of the road-surface points of
//                      conventions §6: RoadSurface::points() (road_surface.h),
//                      each kept 0.4 m BEV cell's min corner at its block's
//                      fitted plane height. Fit once per scene and pass the
//                      RoadSurface to every chunk; the overload without one
//                      fits it from scene.map with opts.surface.
//   6-7  sin θ, cos θ  heading of the max-IoU static vehicle box, written when
//                      its intersection with the voxel cube > 0.5 · 0.256 m³
// Volume layout: float [C][X=i][Y=j][Z=k], 64³ per channel, X slowest.
//
// Map points (road-edge and road-line polylines resampled at 0.25 m, the
// surface points as they are): world (double) -> chunk frame -> grid coordinate
// q = p / vs - 0.5 + 32 in double, rounded to float (that float is exactly
// what the GPU kernel gets); voxel = roundEven(q) (torch.round), kept when in
// [0, 64)³. Points with q outside [-1, 65] are dropped on the host.
// Boxes: static (never moved > 0.05 m between consecutive valid states,
// ObjectType::Vehicle, not the ego) with a valid state at the time index,
// transformed to the chunk frame in double; boxes whose bounds miss the chunk
// are dropped. The "healthy box" self-overlap filter of upstream is not applied.
// Each latent voxel is the cell [ijk·vs, (ijk+1)·vs]; exact volume/IoU from
// box_overlap.h; ties in IoU go to the first box.
#pragma once

#include "scene/scene.h"
#include "world/box_overlap.h"
#include "world/chunk_pose.h"
#include "world/road_surface.h"

#include <glm/glm.hpp>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace icube::world {

inline constexpr int kCondChannels = 8;
inline constexpr int kCondI = 0, kCondJ = 1, kCondK = 2, kCondRoadEdge = 3, kCondRoadLine = 4, kCondRoadSurface = 5,
                     kCondSin = 6, kCondCos = 7;
inline constexpr size_t kCondVoxels = static_cast<size_t>(kLatentDim) * kLatentDim * kLatentDim;
inline constexpr double kLatentCellVolume = 0.8 * 0.8 * 0.4;
inline constexpr double kBoxOccupancyFraction = 0.5;

inline size_t cond_index(int channel, int x, int y, int z) {
  return ((static_cast<size_t>(channel) * kLatentDim + static_cast<size_t>(x)) * kLatentDim + static_cast<size_t>(y)) *
             kLatentDim +
         static_cast<size_t>(z);
}

struct ConditionOptions {
  int time_index = 0;               // which Scene::timestamps entry the boxes come from
  RoadSurfaceOptions surface;       // the fit, when no RoadSurface is passed (cell 0.4 m, upstream's)
  bool include_dynamic = false;     // true: moving vehicles too (training-style)
};

// A box in the chunk frame with its heading encoding.
struct ChunkBox {
  OrientedBox box;
  double sin_heading = 0.0, cos_heading = 1.0;
};

// Everything the CPU reference and the GPU kernels consume, already in the chunk frame.
struct ConditionInputs {
  std::vector<glm::vec3> edge_grid, line_grid, surface_grid;  // float grid coordinates q
  std::vector<ChunkBox> boxes;
};

// World points -> float grid coordinates (appended to `out`), dropping far points.
void append_grid_points(std::vector<glm::vec3>& out, const std::vector<glm::dvec3>& world_points,
                        const glm::dmat4& world_to_chunk);
// Static vehicle boxes of `scene` at opts.time_index, in the chunk frame.
std::vector<ChunkBox> chunk_boxes(const scene::Scene& scene, const ChunkPose& pose, const ConditionOptions& opts);
// road_surface from `surface` (build_road_surface(scene.map, ...) once per scene).
ConditionInputs gather_condition_inputs(const scene::Scene& scene, const ChunkPose& pose, const RoadSurface& surface,
                                        const ConditionOptions& opts = {});
// Fits the road surface itself (build_road_surface(scene.map, opts.surface)): one chunk only.
ConditionInputs gather_condition_inputs(const scene::Scene& scene, const ChunkPose& pose,
                                        const ConditionOptions& opts = {});

// The latent cell of voxel (x, y, z) (x, y, z in [0, 64)) in the chunk frame.
AxisBox latent_cell(int x, int y, int z);

// Plain-loop CPU reference: the [8, 64, 64, 64] volume.
std::vector<float> build_conditions_cpu(const ConditionInputs& in);
// The per-voxel max intersection volume of the chosen box (diagnostics and tests), 64³.
std::vector<double> box_intersections_cpu(const ConditionInputs& in);

}  // namespace icube::world
