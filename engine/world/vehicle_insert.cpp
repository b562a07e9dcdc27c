// insert_vehicles(): the static vehicles of one scene state into a VoxelGrid
// with their instance ids (vehicle_insert.h; the single-mesh form in mesh_voxelize.h).
#include "world/vehicle_insert.h"

#include "world/mesh_voxelize.h"
#include "world/voxel_grid.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::world {

VehicleInsertStats insert_vehicles(VoxelGrid& grid, const scene::Scene& scene, int time_index,
                                   const VehicleMeshSet& meshes, uint32_t min_sub_voxels, const VehicleFilter& keep) {
  if (meshes.types.empty()) throw std::invalid_argument("insert_vehicles: no vehicle meshes");
  if (time_index < 0 || (!scene.timestamps.empty() && time_index >= static_cast<int>(scene.timestamps.size())))
    throw std::out_of_range("insert_vehicles: time index " + std::to_string(time_index) + " out of range");
  std::vector<const scene::Track*> cars;
  for (const auto& t : scene.tracks) {
    if (t.type != scene::ObjectType::Vehicle || t.dynamic) continue;
    if (static_cast<size_t>(time_index) >= t.states.size() || !t.states[static_cast<size_t>(time_index)].valid)
      continue;
    if (keep && !keep(t, t.states[static_cast<size_t>(time_index)])) continue;
    if (t.instance_id > 0xFFFFu)
      throw std::invalid_argument("insert_vehicles: instance id " + std::to_string(t.instance_id) + " of track " +
                                  std::to_string(t.id) + " does not fit the grid's uint16");
    cars.push_back(&t);
  }
  std::stable_sort(cars.begin(), cars.end(),
                   [](const scene::Track* a, const scene::Track* b) { return a->instance_id < b->instance_id; });
  VehicleInsertStats st;
  st.vehicles = cars.size();
  st.per_type.assign(meshes.types.size(), 0);
  VoteOptions opts;
  opts.cell = grid.voxel_size();
  opts.grid_origin = grid.origin();
  opts.min_sub_voxels = min_sub_voxels;
  for (const auto* t : cars) {
    const scene::BoxState& box = t->states[static_cast<size_t>(time_index)];
    const VehicleType& type = meshes.pick(box.length);
    ++st.per_type[static_cast<size_t>(&type - meshes.types.data())];
    opts.class_id = type.class_id;
    for (const auto& v : voxelize_vehicle(type.mesh, box, t->instance_id, opts)) {
      if (!ijk_in_range(v.ijk) || grid.contains(v.ijk)) continue;  // existing voxels win
      grid.set(v.ijk, v.class_id, static_cast<uint16_t>(v.instance_id));
      ++st.voxels;
    }
  }
  return st;
}

uint64_t insert_vehicles(VoxelGrid& grid, const scene::Scene& scene, int time_index, const TriangleMesh& mesh,
                         uint32_t min_sub_voxels) {
  return insert_vehicles(grid, scene, time_index, mesh, min_sub_voxels, {}, nullptr);
}

uint64_t insert_vehicles(VoxelGrid& grid, const scene::Scene& scene, int time_index, const TriangleMesh& mesh,
                         uint32_t min_sub_voxels,
                         const std::function<bool(const scene::Track&, const scene::BoxState&)>& keep,
                         size_t* inserted) {
  VehicleMeshSet one;
  one.types.emplace_back();  // "car", every length
  one.types.back().mesh = mesh;
  const VehicleInsertStats st = insert_vehicles(grid, scene, time_index, one, min_sub_voxels, keep);
  if (inserted) *inserted = st.vehicles;
  return st.voxels;
}

}  // namespace icube::world
