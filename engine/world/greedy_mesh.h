// Greedy meshing of a VoxelGrid's boundary: every face between an occupied
// and an empty voxel, with coplanar, adjacent faces of the same class and
// facing merged into maximal rectangles (rows first along u, then grown
// along v). Output order is deterministic. Used by world_export.h.
#pragma once

#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace icube::world {

// A rectangle on the plane {x[axis] = plane} (in voxel-corner units, i.e. metres / voxel size
// relative to the grid origin), covering u in [u0, u0 + du) and v in [v0, v0 + dv), where
// u = axis (axis + 1) % 3 and v = axis (axis + 2) % 3. `positive` = the normal points along +axis.
struct MeshQuad {
  uint8_t class_id = 0;
  uint8_t axis = 0;
  bool positive = true;
  int32_t plane = 0;
  int32_t u0 = 0, v0 = 0;
  int32_t du = 1, dv = 1;
};

std::vector<MeshQuad> greedy_mesh(const VoxelGrid& grid);

// The quad's four corners in voxel-corner units, counter-clockwise seen from the side its normal points to.
std::array<glm::ivec3, 4> quad_corners(const MeshQuad& q);

}  // namespace icube::world
