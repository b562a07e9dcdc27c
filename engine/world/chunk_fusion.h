// Chunk fusion (conventions §9.4, InfiniCube's `_update_scene_grid`): a
// generated chunk is moved into the world and merged with the voxels already
// there winning, no blending.
//
// When the chunk's lattice is the world's lattice shifted by whole voxels
// (same voxel size, rotation the identity to 1e-12, translation a multiple of
// the voxel size to 1e-6 voxel), its cells are copied exactly. Otherwise it is
// re-voxelised as upstream does: every chunk voxel is subdivided x2 per axis,
// the 8 sub-voxel centres are transformed to the world in double, each falls
// into world cell floor((p - origin) / vs) carrying its parent's class and
// instance, and a cell takes the majority class of the sub-voxels that fall
// into it (ties to the lowest class id), with the instance of the first such
// sub-voxel of that class (chunk voxel order). Then cells already occupied in
// the world keep their voxel.
#pragma once

#include "world/generator.h"
#include "world/voxel_grid.h"

#include <cstdint>

namespace icube::world {

struct FusionStats {
  uint64_t chunk_voxels = 0;   // voxels in the chunk
  uint64_t cells = 0;          // distinct world cells they cover
  uint64_t written = 0;        // cells that were empty and got a voxel
  uint64_t kept_existing = 0;  // cells already occupied (existing voxel won)
  uint64_t out_of_range = 0;   // cells outside the grid's ijk range (dropped)
  bool exact_copy = false;     // the lattice fast path was taken
};

// True when `chunk`'s lattice is `world`'s shifted by whole voxels; `shift` gets the ijk offset.
bool lattice_aligned(const ChunkVoxels& chunk, const VoxelGrid& world, glm::ivec3* shift = nullptr);

FusionStats fuse_chunk(VoxelGrid& world, const ChunkVoxels& chunk);

}  // namespace icube::world
