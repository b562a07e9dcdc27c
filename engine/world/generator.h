// The interface between chunk planning and whatever fills a chunk with
// voxels: the procedural world prior (procedural/procedural_prior.h) today,
// the map-conditioned latent diffusion model later. world_build.h drives a
// generator over a ChunkPlan and fuses every chunk into the world
// (chunk_fusion.h), so every generator goes through the same planning and
// fusion.
#pragma once

#include "world/chunk_plan.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace icube::scene {
struct Scene;
}

namespace icube::world {

struct ChunkVoxel {
  glm::ivec3 ijk{0};
  uint8_t class_id = 0;   // 1..22
  uint16_t instance = 0;
};

// A generated chunk. Voxel ijk is the cube of side voxel_size centred at
// lattice_to_world * ((ijk + 0.5) * voxel_size), axes along the columns of
// lattice_to_world (rigid, double precision).
//   - A learned generator works in the chunk frame: lattice_to_world =
//     ChunkPose::chunk_to_world and ijk in [-128, 128) x [-128, 128) x [-64, 64)
//     (fVDB's centres ijk * 0.2 + 0.1, conventions §2).
//   - A generator that can evaluate the world directly (the procedural prior)
//     may emit cells of the world's own lattice: lattice_to_world = a
//     translation by the world grid's origin. Fusion then copies cells
//     exactly instead of re-voxelising.
struct ChunkVoxels {
  glm::dmat4 lattice_to_world{1.0};
  double voxel_size = kFineVoxel;
  std::vector<ChunkVoxel> voxels;  // unique ijk
};

struct ChunkRequest {
  const scene::Scene* scene = nullptr;
  const ChunkPlan* plan = nullptr;
  size_t chunk = 0;                    // index into plan->chunks
  glm::dvec3 world_origin{0.0};        // the world grid's origin (its lattice)
  double world_voxel_size = kFineVoxel;
  const VoxelGrid* world = nullptr;    // the world so far (outpainting context); read-only
  uint64_t seed = 0;
};

class WorldGenerator {
 public:
  virtual ~WorldGenerator() = default;
  virtual std::string name() const = 0;
  // Must be safe to call concurrently for different chunks (world_build runs
  // chunks on several threads when the generator does not read `world`).
  virtual ChunkVoxels generate(const ChunkRequest& request) const = 0;
  // True when generate() reads request.world (then chunks run in plan order, one at a time).
  virtual bool reads_world() const { return false; }
};

}  // namespace icube::world
