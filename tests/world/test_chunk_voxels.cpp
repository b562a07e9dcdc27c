// World voxels re-voxelised into a chunk's frame (engine/world/chunk_voxels.h):
// a translation-only chunk on the world's lattice maps voxels one to one, a
// chunk turned by 90 degrees too, voxels outside the box are left out, and a
// tie between classes goes to the lowest id.
#include "world/chunk_voxels.h"

#include <doctest/doctest.h>

#include <cmath>

using namespace icube;

TEST_CASE("chunk voxels: the world's voxels in a chunk's fVDB frame") {
  world::VoxelGrid w(glm::dvec3(0.0), 0.2);  // centres at (ijk + 0.5) * 0.2
  w.set({0, 0, 0}, 17);
  w.set({5, -3, 2}, 1);
  w.set({1000, 0, 0}, 2);   // 200 m away: outside the chunk
  w.set({0, 0, 70}, 3);     // above the box (z half extent 12.8 m = 64 voxels)
  world::ChunkPose at_origin;  // chunk frame = world frame: chunk ijk = world ijk (centres ijk * 0.2 + 0.1)
  world::ChunkVoxelList v = world::chunk_voxels(w, at_origin);
  REQUIRE(v.ijk.size() == 2);
  CHECK(v.ijk[0] == std::array<int32_t, 3>{0, 0, 0});
  CHECK(v.class_id[0] == 17);
  CHECK(v.ijk[1] == std::array<int32_t, 3>{5, -3, 2});
  // Shifted by whole voxels and turned by 90 degrees about z: world (x, y) = (-y', x') + shift.
  world::ChunkPose turned;
  turned.chunk_to_world = glm::dmat4(glm::dvec4(0, 1, 0, 0), glm::dvec4(-1, 0, 0, 0), glm::dvec4(0, 0, 1, 0), glm::dvec4(2.0, 0.0, 0.0, 1));
  v = world::chunk_voxels(w, turned);
  REQUIRE(v.ijk.size() == 2);
  // World voxel (0,0,0): centre (0.1, 0.1, 0.1) -> chunk (0.1, 1.9, 0.1) -> ijk (0, 9, 0);
  // (5,-3,2): centre (1.1, -0.5, 0.5) -> chunk (-0.5, 0.9, 0.5) -> ijk (-3, 4, 2) (ascending order).
  CHECK(v.ijk[0] == std::array<int32_t, 3>{-3, 4, 2});
  CHECK(v.class_id[0] == 1);
  CHECK(v.ijk[1] == std::array<int32_t, 3>{0, 9, 0});
  CHECK(v.class_id[1] == 17);
  // Two world voxels of different classes in one chunk voxel: a tie goes to the lower id.
  world::VoxelGrid fine(glm::dvec3(0.0), 0.1);
  fine.set({0, 0, 0}, 9);
  fine.set({1, 0, 0}, 4);
  v = world::chunk_voxels(fine, at_origin);
  REQUIRE(v.ijk.size() == 1);
  CHECK(v.class_id[0] == 4);
}
