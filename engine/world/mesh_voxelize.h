// Vehicle insertion: a CAD car mesh fitted into an object box, voxelised at
// 0.1 m in the box frame and voted into the 0.2 m world grid (conventions §2,
// §5), as InfiniCube does with its car.ply for every vehicle box.
//
// 1. Fit: the mesh's AABB is scaled per axis to the box (x = length,
//    y = width, z = height) and centred, so the mesh bottom sits on the box
//    bottom. An axis on which the mesh is flat maps to the box's mid-plane.
// 2. Voxelise in the box frame: sub-voxel ijk has centre (ijk + 0.5)·0.1 m
//    (the fVDB lattice with origin 0.05); the result holds the sub-voxels
//    whose centres lie in the closed box (the shell and fill below run on all
//    sub-voxels overlapping the box, so a partial outer layer still closes
//    the shell). Surface: every sub-voxel whose closed
//    cube (1 nm tolerance) overlaps a triangle by the separating-axis test
//    (Akenine-Möller's 13 axes). Interior: everything a 6-connected flood fill
//    from outside the box cannot reach through the surface shell. A
//    conservative shell is 26-separating, so a watertight mesh never leaks; a
//    mesh with holes larger than a sub-voxel yields its shell only.
// 3. Vote: each sub-voxel centre goes to the world with box_to_world and falls
//    into cell floor((p - grid_origin) / 0.2). A cell is CAR when at least
//    `min_sub_voxels` centres fall into it. The default, 1, is InfiniCube's
//    rule: points_to_fvdb majority-votes the classes of the points in a cell
//    and empty is not a class, so one car point makes a car cell (when no
//    other class's points outvote it; vehicle_insert.cpp lets existing voxels
//    win instead). It overestimates volume by the half-covered rim: a
//    4 x 2 x 1.6 m box at heading 30 degrees gives +7.5 % with its bottom on
//    the 0.2 m lattice and +21 % with it 0.1 m off (a ninth cell layer);
//    min_sub_voxels = 4 (half of the 8 a cell holds) gives +2.5 % and +7.6 %
//    (tests/world/test_mesh_voxelize.cpp).
// A box with a zero, negative or non-finite dimension has no volume and gives
// no voxels (not an error: Waymo has boxes of zero height). A box spanning
// more than kMaxBoxSubVoxels sub-voxels throws std::invalid_argument.
#pragma once

#include "scene/scene.h"
#include "world/semantics.h"
#include "world/triangle_mesh.h"

#include <glm/glm.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace icube::world {

class VoxelGrid;

inline constexpr double kCarSubVoxel = 0.1;
// The most sub-voxels (with one padding layer) one box may span: 2^28, a
// 256 MiB work grid, e.g. 64 x 64 x 64 m at 0.1 m.
inline constexpr size_t kMaxBoxSubVoxels = size_t{1} << 28;

// The mesh scaled into the box frame (centre at the origin), step 1 above.
// Empty when the mesh or the box is empty.
TriangleMesh fit_mesh_to_box(const TriangleMesh& mesh, double length, double width, double height);

struct BoxVoxelization {
  std::vector<glm::ivec3> sub_voxels;  // box-frame ijk, centre (ijk + 0.5)·sub_voxel; sorted (x, then y, then z)
  double sub_voxel = kCarSubVoxel;
  size_t surface = 0, interior = 0;    // surface + interior = sub_voxels.size()
};

// Steps 1 and 2.
BoxVoxelization voxelize_mesh_in_box(const TriangleMesh& mesh, double length, double width, double height,
                                     double sub_voxel = kCarSubVoxel);

struct VehicleVoxel {
  glm::ivec3 ijk{0};  // world cell, floor((p - grid_origin) / cell)
  uint8_t class_id = static_cast<uint8_t>(SemanticClass::Car);
  uint32_t instance_id = 0;
  uint32_t sub_voxels = 0;  // how many sub-voxel centres fell into the cell
};

struct VoteOptions {
  double cell = 0.2;
  glm::dvec3 grid_origin{0.0};
  uint32_t min_sub_voxels = 1;
  uint8_t class_id = static_cast<uint8_t>(SemanticClass::Car);
};

// Step 3. Sorted by ijk (x, then y, then z). Far boxes keep full precision: the
// box centre's whole cells are split off in double before the rotation.
// Throws std::out_of_range when a cell index would not fit in int32.
std::vector<VehicleVoxel> vote_into_cells(const BoxVoxelization& vox, const scene::BoxState& box, uint32_t instance_id,
                                          const VoteOptions& options = {});

// Steps 1-3 for one box.
std::vector<VehicleVoxel> voxelize_vehicle(const TriangleMesh& mesh, const scene::BoxState& box, uint32_t instance_id,
                                           const VoteOptions& options = {});

// (vehicle_insert.cpp; vehicle_insert.h has the form with a mesh and class per
// vehicle type) Inserts the static vehicles of scene state `time_index`
// (ObjectType::Vehicle tracks, not dynamic, valid at the index) as CAR voxels
// with their instance ids, in increasing instance-id order; voxels already in
// the grid win, so where two cars overlap the lower id keeps the cell. Uses
// the grid's origin and voxel size. Returns the number of voxels written.
// Throws std::out_of_range for a bad time index and std::invalid_argument for
// an instance id above 65535 (the grid stores uint16).
uint64_t insert_vehicles(VoxelGrid& grid, const scene::Scene& scene, int time_index, const TriangleMesh& mesh,
                         uint32_t min_sub_voxels = 1);
// The same for the tracks `keep` accepts (given the track and its state at `time_index`);
// `inserted` (optional) gets the number of vehicles that passed the filter.
uint64_t insert_vehicles(VoxelGrid& grid, const scene::Scene& scene, int time_index, const TriangleMesh& mesh,
                         uint32_t min_sub_voxels,
                         const std::function<bool(const scene::Track&, const scene::BoxState&)>& keep,
                         size_t* inserted = nullptr);

}  // namespace icube::world
