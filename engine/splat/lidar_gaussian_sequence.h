// LiDAR sweeps of a splat scene along a trajectory of sensor poses, the
// Gaussian counterpart of render/lidar/lidar_sequence.h: each pose's frame of
// the scene (the static set, or static + objects placed at the frame) is
// composed and uploaded when the frame changes; a set over what one upload
// takes is cast per sweep through the Gaussians the sweep can reach
// (LidarGaussiansGpu::upload_within_reach: the same scan), uploaded at every
// pose. Scans go to a callback one by one (a waymo-top sweep has up to 170k
// returns). Used by `icube lidar --gaussians` and `icube eval`.
// Tests: tests/splat/test_lidar_gaussians.cpp.
#pragma once

#include "render/buffers/trajectory.h"
#include "render/lidar/lidar_scan.h"
#include "splat/lidar_gaussians_gpu.h"
#include "splat/splat_scene.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace icube::splat {

struct LidarGaussianSequenceOptions {
  LidarGaussianOptions cast;
  // The scene frame of each pose; empty: the pose's time_index (0 where it has none or the scene no objects).
  std::vector<size_t> scene_frames;
  std::function<void(const render::LidarScan&)> on_frame;  // each scan, in trajectory order
  std::function<void(size_t done, size_t total)> progress;
};

struct LidarGaussianSequenceStats {
  size_t frames = 0, max_gaussians = 0;
  size_t culled_sweeps = 0;  // sweeps cast through the Gaussians within reach (the set over one upload)
  uint64_t rays = 0, returns = 0, instances = 0;
  double compose_s = 0, cast_s = 0, gpu_ms = 0, sink_s = 0;  // compose + upload, sweeps (wall), GPU, the callback
};

LidarGaussianSequenceStats cast_lidar_gaussian_sequence(LidarGaussiansGpu& caster, const SplatScene& scene,
                                                        const render::Trajectory& traj,
                                                        const LidarGaussianSequenceOptions& options);

}  // namespace icube::splat
