// One object (a user's mesh in an oriented box) into an existing world, as
// `icube world insert` does: the mesh is fitted to the box and voxelised like
// a vehicle (mesh_voxelize.h), with one class and one instance id.
#pragma once

#include "scene/scene.h"
#include "world/semantics.h"
#include "world/triangle_mesh.h"

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace icube::world {

class VoxelGrid;

struct ObjectInsertOptions {
  uint8_t class_id = static_cast<uint8_t>(SemanticClass::Car);
  uint32_t instance_id = 0;  // 0: next_instance_id(grid)
  bool overwrite = false;    // false: voxels already in the grid win
  uint32_t min_sub_voxels = 1;
};

struct ObjectInsertResult {
  uint32_t instance_id = 0;
  size_t cells = 0;            // cells the object covers
  uint64_t written = 0;        // cells set (new + replaced)
  uint64_t replaced = 0;       // cells that held another voxel and were overwritten
  uint64_t kept_existing = 0;  // cells left to the voxel already there
  uint64_t out_of_range = 0;   // cells beyond the grid's +-2^23 voxel range
};

// "cx,cy,cz,l,w,h,heading": box centre (metres, world frame, z up; cz is the
// centre, not the bottom), length along the heading, width, height (metres,
// positive) and heading (yaw of the length axis, counter-clockwise from +x:
// radians, or degrees with a "deg" suffix, e.g. "90deg"). Throws
// std::invalid_argument with a one-line message naming the field.
scene::BoxState parse_box_spec(std::string_view text);

// 1 + the largest instance id in the grid (1 when it has none). Throws
// std::invalid_argument when that exceeds 65535 (the grid stores uint16).
uint32_t next_instance_id(const VoxelGrid& grid);

// Throws std::invalid_argument for a box with a non-finite value or a size
// that is not positive, a class outside 1..22 or an instance id above 65535.
ObjectInsertResult insert_object(VoxelGrid& grid, const TriangleMesh& mesh, const scene::BoxState& box,
                                 const ObjectInsertOptions& options = {});

}  // namespace icube::world
