// Static vehicles of a scene state into a VoxelGrid, each voxelised with the
// mesh and class its box length picks from a VehicleMeshSet
// (vehicle_mesh_set.h). The single-mesh insert_vehicles() of mesh_voxelize.h
// is this with one "car" type.
#pragma once

#include "scene/scene.h"
#include "world/vehicle_mesh_set.h"

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace icube::world {

class VoxelGrid;

struct VehicleInsertStats {
  uint64_t voxels = 0;           // voxels written
  size_t vehicles = 0;           // vehicles that passed the filter
  std::vector<size_t> per_type;  // vehicles per set.types entry
};

using VehicleFilter = std::function<bool(const scene::Track&, const scene::BoxState&)>;

// The static vehicles of state `time_index` (ObjectType::Vehicle, not
// dynamic, valid there, accepted by `keep` when given) in increasing
// instance-id order; voxels already in the grid win. Throws
// std::out_of_range for a bad time index and std::invalid_argument for an
// instance id above 65535 or an empty set.
VehicleInsertStats insert_vehicles(VoxelGrid& grid, const scene::Scene& scene, int time_index,
                                   const VehicleMeshSet& meshes, uint32_t min_sub_voxels = 1,
                                   const VehicleFilter& keep = {});

}  // namespace icube::world
