// Stage 1 driver: plan the chunks a scene needs, fill each one with a
// WorldGenerator, fuse it into one world (existing voxels win, chunk order),
// then insert the static vehicles whose boxes lie in a planned chunk.
//
// The world grid is axis-aligned in the scene's world frame (z up), 0.2 m,
// with its origin at the first chunk's centre rounded to the 0.2 m lattice,
// so ijk stay small for scenes far from the origin. (InfiniCube's world frame
// is the first camera's FLU frame; ours stays gravity-aligned, and the
// guidance-buffer writer expresses poses in InfiniCube's frame.)
//
// Determinism: the result depends only on the scene, the options and the
// seed, never on the thread count (chunks may be generated in parallel but are
// fused in plan order).
#pragma once

#include "world/chunk_plan.h"
#include "world/chunk_fusion.h"
#include "world/generator.h"
#include "world/vehicle_mesh_set.h"
#include "world/voxel_grid.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace icube::world {

struct WorldBuildOptions {
  PlanMode mode = PlanMode::Trajectory;
  PlanOptions plan;
  uint64_t seed = 0;
  bool insert_static_vehicles = true;
  int vehicle_time_index = 0;
  // Mesh and class per static vehicle, picked by box length (vehicle_mesh_set.h);
  // nullptr: the built-in car for every vehicle.
  const VehicleMeshSet* vehicle_meshes = nullptr;
  int threads = 0;                          // 0: hardware concurrency
  // Called after each chunk is fused: (chunks done, chunks total).
  std::function<void(size_t, size_t)> progress;
};

struct ChunkBuildStats {
  FusionStats fusion;
  double generate_s = 0.0, fuse_s = 0.0;
};

struct WorldBuildResult {
  VoxelGrid world;
  ChunkPlan plan;
  std::vector<ChunkBuildStats> chunks;  // plan order
  uint64_t vehicle_voxels = 0;
  size_t vehicles_inserted = 0;
  std::vector<size_t> vehicles_per_type;  // per vehicle_meshes->types entry (or the built-in car)
  double plan_s = 0.0, generate_s = 0.0, fuse_s = 0.0, vehicles_s = 0.0, total_s = 0.0;
};

// Throws scene::InputError when the scene cannot be planned (see chunk_plan.h).
WorldBuildResult build_world(const scene::Scene& scene, const WorldGenerator& generator,
                             const WorldBuildOptions& options = {});

// The world grid's origin for a world that starts with chunk `first`: its centre rounded to the
// lattice of voxel size `vs` (halves round up, so a translated scene gets the translated origin).
glm::dvec3 world_lattice_origin(const ChunkPose& first, double vs = kFineVoxel);

// The chunk's crop box test: p (world) inside chunk `pose`'s box
// (|x|, |y| <= 25.6, |z| <= 12.8 in the chunk frame), with `margin` metres of slack.
bool inside_chunk(const ChunkPose& pose, const glm::dvec3& p, double margin = 0.0);

}  // namespace icube::world
