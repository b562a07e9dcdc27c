// Static scene and per-frame dynamic cars; see frame_scene.h.
#include "render/buffers/frame_scene.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>

namespace icube::render {

namespace {

struct IjkLess {
  bool operator()(const glm::ivec3& a, const glm::ivec3& b) const {
    return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
  }
};

const scene::BoxState* state_at(const scene::Track& t, int time_index) {
  if (time_index >= 0 && static_cast<size_t>(time_index) < t.states.size() &&
      t.states[static_cast<size_t>(time_index)].valid)
    return &t.states[static_cast<size_t>(time_index)];
  return nullptr;
}

void check_instance(const scene::Track& t) {
  if (t.instance_id > 0xFFFFu)
    throw std::invalid_argument("guidance buffers: instance id " + std::to_string(t.instance_id) + " of track " +
                                std::to_string(t.id) + " does not fit uint16");
}

}  // namespace

std::vector<CarCell> merge_car_cells(const std::vector<std::vector<world::VehicleVoxel>>& cars) {
  struct Best {
    uint32_t sub = 0;
    uint32_t instance = 0;
  };
  std::map<glm::ivec3, Best, IjkLess> cells;
  for (const auto& car : cars)
    for (const world::VehicleVoxel& v : car) {
      if (!world::ijk_in_range(v.ijk)) continue;
      auto [it, fresh] = cells.try_emplace(v.ijk, Best{v.sub_voxels, v.instance_id});
      if (fresh) continue;
      Best& b = it->second;
      if (v.sub_voxels > b.sub || (v.sub_voxels == b.sub && v.instance_id < b.instance)) b = {v.sub_voxels, v.instance_id};
    }
  std::vector<CarCell> out;
  out.reserve(cells.size());
  for (const auto& [ijk, b] : cells) out.push_back({ijk, static_cast<uint16_t>(b.instance)});
  return out;
}

world::VoxelGrid make_static_world(const world::VoxelGrid& src, const scene::Scene& s, int time_index,
                                   const world::TriangleMesh& mesh, StaticSceneStats* stats) {
  StaticSceneStats st;
  world::VoxelGrid g(src.origin(), src.voxel_size());
  // Bricks without vehicle voxels are copied whole; the others voxel by voxel.
  for (uint32_t idx : src.sorted_brick_order()) {
    const world::Brick& b = src.bricks()[idx];
    world::Brick kept = b;
    bool changed = false;
    for (int n = 0; n < world::kBrickVoxels; ++n) {
      const uint64_t bit = uint64_t{1} << (n % 64);
      if (!(b.mask[static_cast<size_t>(n / 64)] & bit) || !world::is_vehicle_class(b.classes[static_cast<size_t>(n)]))
        continue;
      kept.mask[static_cast<size_t>(n / 64)] &= ~bit;
      kept.classes[static_cast<size_t>(n)] = 0;
      kept.instances[static_cast<size_t>(n)] = 0;
      ++st.vehicle_voxels_removed;
      changed = true;
    }
    if (!changed || kept.count() > 0) g.insert_brick(kept);
  }
  world::VoteOptions vo;
  vo.cell = src.voxel_size();
  vo.grid_origin = src.origin();
  std::vector<std::vector<world::VehicleVoxel>> cars;
  for (size_t i = 0; i < s.tracks.size(); ++i) {
    const scene::Track& t = s.tracks[i];
    if (t.type != scene::ObjectType::Vehicle || t.dynamic || scene::is_ego_track(s, i)) continue;
    const scene::BoxState* b = state_at(t, time_index);
    for (size_t k = 0; !b && k < t.states.size(); ++k)
      if (t.states[k].valid) b = &t.states[k];
    if (!b) continue;
    check_instance(t);
    cars.push_back(world::voxelize_vehicle(mesh, *b, t.instance_id, vo));
    ++st.static_cars;
  }
  for (const CarCell& c : merge_car_cells(cars)) {
    g.set(c.ijk, static_cast<uint8_t>(world::SemanticClass::Car), c.instance);
    ++st.car_cells;
  }
  if (stats) *stats = st;
  return g;
}

std::vector<CarCell> dynamic_car_cells(const scene::Scene& s, int time_index, const world::TriangleMesh& mesh,
                                       const glm::dvec3& grid_origin, double voxel_size, size_t* n_cars,
                                       CarVoxelCache* cache) {
  world::VoteOptions vo;
  vo.cell = voxel_size;
  vo.grid_origin = grid_origin;
  std::vector<std::pair<const scene::BoxState*, uint32_t>> boxes;
  for (size_t i = 0; i < s.tracks.size(); ++i) {
    const scene::Track& t = s.tracks[i];
    if (t.type != scene::ObjectType::Vehicle || !t.dynamic || scene::is_ego_track(s, i)) continue;
    const scene::BoxState* b = scene::state_filled(t, time_index);
    if (!b) continue;
    check_instance(t);
    boxes.emplace_back(b, t.instance_id);
  }
  // Box-frame voxelisations: from the cache, else computed (in the parallel loop) and cached after.
  std::vector<const world::BoxVoxelization*> vox(boxes.size(), nullptr);
  std::vector<world::BoxVoxelization> fresh(boxes.size());
  if (cache)
    for (size_t k = 0; k < boxes.size(); ++k) {
      const auto it = cache->boxes.find({boxes[k].first->length, boxes[k].first->width, boxes[k].first->height});
      if (it != cache->boxes.end()) vox[k] = &it->second;
    }
  // One car per task on up to hardware_concurrency threads; the result does not depend on the count.
  std::vector<std::vector<world::VehicleVoxel>> cars(boxes.size());
  std::atomic<size_t> next{0};
  std::exception_ptr err;
  std::mutex mu;
  auto worker = [&] {
    for (size_t k = next++; k < boxes.size(); k = next++) {
      try {
        const scene::BoxState& b = *boxes[k].first;
        if (!vox[k]) {
          fresh[k] = world::voxelize_mesh_in_box(mesh, b.length, b.width, b.height);
          vox[k] = &fresh[k];
        }
        cars[k] = world::vote_into_cells(*vox[k], b, boxes[k].second, vo);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mu);
        if (!err) err = std::current_exception();
      }
    }
  };
  const size_t threads = std::min<size_t>(boxes.size(), std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (size_t k = 1; k < threads; ++k) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (err) std::rethrow_exception(err);
  if (cache)
    for (size_t k = 0; k < boxes.size(); ++k)
      if (vox[k] == &fresh[k])
        cache->boxes.try_emplace({boxes[k].first->length, boxes[k].first->width, boxes[k].first->height},
                                 std::move(fresh[k]));
  if (n_cars) *n_cars = cars.size();
  return merge_car_cells(cars);
}

}  // namespace icube::render
