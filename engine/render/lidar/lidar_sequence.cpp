// LiDAR sweeps along a trajectory with per-frame dynamic cars; see lidar_sequence.h.
#include "render/lidar/lidar_sequence.h"

#include "render/buffers/dynamic_cars.h"
#include "render/buffers/overlay_world.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace icube::render {

namespace {
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
}  // namespace

Trajectory lidar_ego_trajectory(const scene::Scene& s, const glm::dmat4& sensor_to_ego) {
  Trajectory t;
  for (size_t i = 0; i < s.ego.size(); ++i) {
    if (!s.ego[i].valid) continue;
    t.c2w.push_back(s.ego[i].ego_to_world * sensor_to_ego);
    t.frame_index.push_back(static_cast<int>(i));
    t.time_index.push_back(static_cast<int>(i));
  }
  return t;
}

LidarSequenceStats cast_lidar_sequence(gpu::Context& ctx, OverlayWorld& world, const scene::Scene* scene,
                                       const world::TriangleMesh& mesh, const LidarModel& model,
                                       const Trajectory& traj, const LidarSequenceOptions& opts) {
  if (traj.size() == 0) throw std::invalid_argument("lidar: empty trajectory");
  LidarCaster caster(ctx, model);
  LidarSequenceStats st;
  const RaycastWorld& rw = world.world();
  DynamicCarOverlay cars(world, scene, mesh);
  DynamicCarCosts car_costs;
  for (size_t f = 0; f < traj.size(); ++f) {
    const int ti = traj.time_index[f];
    cars.set_time(ti, car_costs);
    st.cars_s = car_costs.cars_s;
    st.overlay_s = car_costs.overlay_s;
    st.max_overlay_bricks = car_costs.max_overlay_bricks;
    st.overlay_bytes = car_costs.overlay_bytes;
    auto t0 = Clock::now();
    LidarScan scan = caster.cast(rw, traj.c2w[f]);
    scan.frame_index = traj.frame_index[f];
    scan.time_index = ti;
    st.frames += 1;
    st.rays += model.rays();
    st.returns += scan.returns.size();
    t0 = Clock::now();
    if (opts.on_frame) opts.on_frame(scan);
    st.sink_s += seconds_since(t0);
    if (opts.progress) opts.progress(f + 1, traj.size());
  }
  st.upload_s = caster.upload_s;
  st.cast_s = caster.cast_s;
  st.download_s = caster.download_s;
  st.post_s = caster.post_s;
  return st;
}

}  // namespace icube::render
