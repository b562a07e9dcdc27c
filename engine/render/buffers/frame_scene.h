// The per-frame scene of the guidance buffers (conventions §10.1), split into
// a static part built once and the dynamic cars of each frame.
//
// Static part: the world with every vehicle-class voxel (CAR, TRUCK, BUS,
// OTHER_VEHICLE) deleted, plus every static car (ObjectType::Vehicle, not
// dynamic, not the ego) voxelised from the car mesh (voxelize_vehicle: 0.1 m
// sub-voxels voted into the world's 0.2 m cells) at its state of
// `time_index` (or its first valid state), with its instance id. Car cells
// overwrite static voxels: in InfiniCube's re-voxelisation a car cell's
// sub-voxel points outvote a static voxel's centre, and ties go to the lowest
// class id, CAR = 1.
// Dynamic part of a frame: the dynamic vehicle tracks (not the ego) at the
// frame's time index, voxelised the same way (instance ids >= 10000). A track
// not valid at that index is placed at its nearest later, else nearest
// earlier, valid state (scene::state_filled), as InfiniCube distributes
// dynamic object info over all frames before it inserts the cars.
// Where cars overlap each other, the cell goes to the car with the most
// sub-voxels in it, ties to the lowest instance id (the majority vote of
// points_to_fvdb). Cells outside the grid's ijk range are dropped.
// Without a scene the world is used as it is (its vehicles stay).
#pragma once

#include "scene/scene.h"
#include "world/mesh_voxelize.h"
#include "world/triangle_mesh.h"
#include "world/voxel_grid.h"

#include <array>
#include <cstdint>
#include <map>
#include <vector>

namespace icube::render {

struct CarCell {
  glm::ivec3 ijk{0};
  uint16_t instance = 0;
  bool operator==(const CarCell&) const = default;
};

// Cells of several cars (each list one car's voted cells) merged by the rule
// above; sorted by ijk (x, then y, then z).
std::vector<CarCell> merge_car_cells(const std::vector<std::vector<world::VehicleVoxel>>& cars);

struct StaticSceneStats {
  uint64_t vehicle_voxels_removed = 0;
  size_t static_cars = 0;
  uint64_t car_cells = 0;
};

world::VoxelGrid make_static_world(const world::VoxelGrid& world, const scene::Scene& s, int time_index,
                                   const world::TriangleMesh& mesh, StaticSceneStats* stats = nullptr);

// Box-frame voxelisations of the car mesh by box size (l, w, h): a track keeps
// its size, so each is voxelised once and only voted into cells per frame.
struct CarVoxelCache {
  std::map<std::array<double, 3>, world::BoxVoxelization> boxes;
};

// The dynamic cars of scene state `time_index` (merged cells, the grid's
// origin and voxel size), one car per thread. Same cells with or without a cache.
std::vector<CarCell> dynamic_car_cells(const scene::Scene& s, int time_index, const world::TriangleMesh& mesh,
                                       const glm::dvec3& grid_origin, double voxel_size, size_t* cars = nullptr,
                                       CarVoxelCache* cache = nullptr);

}  // namespace icube::render
