// LiDAR sweeps of a splat scene along a trajectory; see lidar_gaussian_sequence.h.
#include "splat/lidar_gaussian_sequence.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace icube::splat {

LidarGaussianSequenceStats cast_lidar_gaussian_sequence(LidarGaussiansGpu& caster, const SplatScene& scene,
                                                        const render::Trajectory& traj,
                                                        const LidarGaussianSequenceOptions& o) {
  using Clock = std::chrono::steady_clock;
  auto seconds_since = [](Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); };
  if (!o.scene_frames.empty() && o.scene_frames.size() != traj.size())
    throw std::invalid_argument("cast_lidar_gaussian_sequence: " + std::to_string(o.scene_frames.size()) +
                                " scene frames for " + std::to_string(traj.size()) + " poses");
  LidarGaussianSequenceStats st;
  GpuLidarGaussians g;
  size_t uploaded = SIZE_MAX;  // the scene frame in `g`, SIZE_MAX when it holds one pose's subset
  for (size_t f = 0; f < traj.size(); ++f) {
    size_t frame = 0;
    if (!o.scene_frames.empty()) frame = o.scene_frames[f];
    else if (scene.has_objects() && f < traj.time_index.size() && traj.time_index[f] > 0) frame = static_cast<size_t>(traj.time_index[f]);
    if (frame != uploaded) {
      const auto t0 = Clock::now();
      const GaussianCloud cloud = compose_frame(scene, frame);
      st.max_gaussians = std::max(st.max_gaussians, cloud.size());
      if (cloud.size() > caster.max_gaussians()) {
        ++st.culled_sweeps;
        uploaded = SIZE_MAX;  // the next pose reaches other Gaussians
        g = caster.upload_within_reach(cloud, glm::dvec3(traj.c2w[f][3]));
      } else {
        uploaded = frame;
        g = caster.upload(cloud, lidar_gaussian_intensity(cloud));
      }
      st.compose_s += seconds_since(t0);
    }
    LidarGaussianTimings tm;
    auto t0 = Clock::now();
    render::LidarScan s = caster.scan(g, traj.c2w[f], o.cast, &tm);
    st.cast_s += seconds_since(t0);
    st.gpu_ms += tm.bin_ms + tm.sort_ms + tm.cast_ms;
    st.instances += tm.instances;
    s.frame_index = traj.frame_index[f];
    s.time_index = traj.time_index[f];
    st.rays += s.range.size();
    st.returns += s.returns.size();
    ++st.frames;
    t0 = Clock::now();
    if (o.on_frame) o.on_frame(s);
    st.sink_s += seconds_since(t0);
    if (o.progress) o.progress(f + 1, traj.size());
  }
  return st;
}

}  // namespace icube::splat
