// DynamicCarOverlay: per-frame dynamic cars into the overlay world (dynamic_cars.h).
#include "render/buffers/dynamic_cars.h"

#include <algorithm>
#include <chrono>

namespace icube::render {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
}  // namespace

DynamicCarOverlay::DynamicCarOverlay(OverlayWorld& world, const scene::Scene* scene, const world::TriangleMesh& mesh)
    : world_(world), scene_(scene), mesh_(mesh) {}

void DynamicCarOverlay::set_time(int time_index, DynamicCarCosts& costs) {
  if (time_index == cached_time_) return;
  auto t0 = Clock::now();
  cells_.clear();
  const RaycastWorld& rw = world_.world();
  if (scene_ && time_index >= 0)
    cells_ = dynamic_car_cells(*scene_, time_index, mesh_, rw.gpu.origin, rw.gpu.voxel_size, nullptr, &cache_);
  cached_time_ = time_index;
  costs.cars_s += seconds_since(t0);
  t0 = Clock::now();
  const OverlayStats st = world_.set_overlay(cells_);
  costs.max_overlay_bricks = std::max(costs.max_overlay_bricks, st.bricks);
  costs.overlay_bytes += st.uploaded_bytes;
  costs.overlay_s += seconds_since(t0);
}

}  // namespace icube::render
