// The latents of the chunks generated so far, as outpainting reads them
// (conventions §9.3). A chunk's latent is the dense 64^3 grid of its frame:
// cell ijk in [-32, 32)^3 centred at (ijk + 0.5) * (0.8, 0.8, 0.4) m, array
// index [c][i + 32][j + 32][k + 32].
//   - Trajectory mode: only the previous chunk's latents are kept; each of its
//     cells is moved into the new chunk's frame (double precision) and written
//     to the nearest cell there (last write wins), as upstream maps the known
//     latents to the nearest current ijk.
//   - Blocks mode: every generated cell lives in a hash keyed by its world
//     latent ijk (relative to the first chunk's lattice, so the x, y shifts of
//     48 cells between blocks are exact; z to the nearest cell), first writer
//     wins; a new block reads the cells its own ijk land on.
// Tests: tests/diffusion/test_latent_store.cpp.
#pragma once

#include "diffusion/chunk_sampler.h"
#include "world/chunk_plan.h"

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace icube::diffusion {

class LatentStore {
 public:
  LatentStore(world::PlanMode mode, int channels);
  // The known latents (clean, as stored) for a chunk at `pose`; empty mask when nothing is known.
  KnownLatents known_for(const world::ChunkPose& pose) const;
  // A finished chunk's latent [C][64^3].
  void add(const world::ChunkPose& pose, const std::vector<float>& latent);
  size_t chunks() const { return chunks_; }

 private:
  uint64_t world_key(const glm::dvec3& p) const;
  world::PlanMode mode_;
  int channels_;
  size_t chunks_ = 0;
  // Trajectory: the previous chunk.
  world::ChunkPose last_pose_;
  std::vector<float> last_latent_;
  // Blocks: world latent ijk -> row of values_ (C floats a row).
  glm::dvec3 reference_{0.0};
  std::unordered_map<uint64_t, uint32_t> rows_;
  std::vector<float> values_;
};

}  // namespace icube::diffusion
