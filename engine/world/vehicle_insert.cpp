// insert_vehicles(): the static cars of one scene state into a VoxelGrid as
// CAR voxels with their instance ids (declared in mesh_voxelize.h).
#include "world/mesh_voxelize.h"
#include "world/voxel_grid.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::world {

uint64_t insert_vehicles(VoxelGrid& grid, const scene::Scene& scene, int time_index, const TriangleMesh& mesh,
                         uint32_t min_sub_voxels) {
  return insert_vehicles(grid, scene, time_index, mesh, min_sub_voxels, {}, nullptr);
}

uint64_t insert_vehicles(VoxelGrid& grid, const scene::Scene& scene, int time_index, const TriangleMesh& mesh,
                         uint32_t min_sub_voxels,
                         const std::function<bool(const scene::Track&, const scene::BoxState&)>& keep,
                         size_t* inserted) {
  if (time_index < 0 || (!scene.timestamps.empty() && time_index >= static_cast<int>(scene.timestamps.size())))
    throw std::out_of_range("insert_vehicles: time index " + std::to_string(time_index) + " out of range");
  std::vector<const scene::Track*> cars;
  for (const auto& t : scene.tracks) {
    if (t.type != scene::ObjectType::Vehicle || t.dynamic) continue;
    if (static_cast<size_t>(time_index) >= t.states.size() || !t.states[static_cast<size_t>(time_index)].valid) continue;
    if (keep && !keep(t, t.states[static_cast<size_t>(time_index)])) continue;
    if (t.instance_id > 0xFFFFu)
      throw std::invalid_argument("insert_vehicles: instance id " + std::to_string(t.instance_id) + " of track " +
                                  std::to_string(t.id) + " does not fit the grid's uint16");
    cars.push_back(&t);
  }
  std::stable_sort(cars.begin(), cars.end(),
                   [](const scene::Track* a, const scene::Track* b) { return a->instance_id < b->instance_id; });
  if (inserted) *inserted = cars.size();
  VoteOptions opts;
  opts.cell = grid.voxel_size();
  opts.grid_origin = grid.origin();
  opts.min_sub_voxels = min_sub_voxels;
  uint64_t written = 0;
  for (const auto* t : cars) {
    for (const auto& v : voxelize_vehicle(mesh, t->states[static_cast<size_t>(time_index)], t->instance_id, opts)) {
      if (!ijk_in_range(v.ijk) || grid.contains(v.ijk)) continue;  // existing voxels win
      grid.set(v.ijk, v.class_id, static_cast<uint16_t>(v.instance_id));
      ++written;
    }
  }
  return written;
}

}  // namespace icube::world
