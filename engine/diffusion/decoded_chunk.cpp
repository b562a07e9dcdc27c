// VAE decode -> ChunkVoxels; see decoded_chunk.h.
#include "diffusion/decoded_chunk.h"

#include <glm/gtc/matrix_transform.hpp>

namespace icube::diffusion {

world::ChunkVoxels decoded_chunk(const nn::VaeDecoded& d, const glm::dmat4& chunk_to_world, uint64_t* undefined) {
  const nn::SparseGrid& g = d.semantic.grid;
  world::ChunkVoxels chunk;
  chunk.voxel_size = g.voxel_size[0];
  // ChunkVoxels centres are (ijk + 0.5) * vs in the lattice frame; fVDB's are ijk * vs + origin.
  const glm::dvec3 corner(g.origin[0] - g.voxel_size[0] / 2, g.origin[1] - g.voxel_size[1] / 2, g.origin[2] - g.voxel_size[2] / 2);
  chunk.lattice_to_world = chunk_to_world * glm::translate(glm::dmat4(1.0), corner);
  chunk.voxels.reserve(static_cast<size_t>(d.semantic.rows()));
  uint64_t skipped = 0;
  for (int64_t r = 0; r < d.semantic.rows(); ++r) {
    const float* l = d.semantic.row(r);
    int best = 0;
    for (int c = 1; c < d.semantic.channels; ++c)
      if (l[c] > l[best]) best = c;
    if (best == 0) {
      ++skipped;
      continue;
    }
    const nn::Ijk& c = g.ijk[static_cast<size_t>(r)];
    chunk.voxels.push_back({glm::ivec3(c[0], c[1], c[2]), static_cast<uint8_t>(best), 0});
  }
  if (undefined) *undefined = skipped;
  return chunk;
}

}  // namespace icube::diffusion
