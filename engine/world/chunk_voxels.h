// A world's voxels as one Stage-1 chunk sees them (conventions §1, §2): the
// fine 0.2 m lattice of the chunk frame (voxel centres at ijk * 0.2 + 0.1,
// ijk in [-128, 128) x [-128, 128) x [-64, 64), the VAE's input box), filled by
// re-voxelising the world's voxel centres into it — each world voxel whose
// centre falls in the box votes for the chunk voxel round((p - 0.1) / 0.2);
// the majority class wins, ties to the lowest id (points_to_fvdb). A
// translation-only chunk on the world's own 0.2 m lattice maps voxels one to
// one. Tests: tests/world/test_chunk_voxels.cpp.
#pragma once

#include "world/chunk_pose.h"
#include "world/voxel_grid.h"

#include <array>
#include <cstdint>
#include <vector>

namespace icube::world {

struct ChunkVoxelList {
  std::vector<std::array<int32_t, 3>> ijk;  // chunk-frame fVDB ijk, ascending
  std::vector<uint8_t> class_id;            // 1..22
};

ChunkVoxelList chunk_voxels(const VoxelGrid& world, const ChunkPose& chunk);

}  // namespace icube::world
