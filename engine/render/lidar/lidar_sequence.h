// LiDAR sweeps along the scene's ego track with the per-frame dynamic cars
// of the guidance buffers: the static scene on the GPU once (OverlayWorld,
// built by the caller from make_static_world), each frame's dynamic car cells
// (dynamic_car_cells, cached per box size) patched in when the frame's scene
// state changes, then one LidarCaster sweep per frame. Exactly the
// frame_scene / overlay_world path of guidance_sequence.h.
//
// Trajectory: render::Trajectory with c2w = SENSOR-TO-WORLD (sensor FLU
// axes, not OpenCV) in the scene's world frame: pose_i = ego_to_world_i ·
// sensor_to_ego for every valid ego pose i, frame_index = time_index = i, so
// select_frames / parse_frame_range (--frames A:B) apply unchanged.
// Scans are handed to a callback one by one and not kept (a waymo-top sweep
// has up to 170k returns).
// Tests: tests/render/test_lidar.cpp.
#pragma once

#include "render/buffers/frame_scene.h"
#include "render/buffers/trajectory.h"
#include "render/lidar/lidar_scan.h"
#include "scene/scene.h"
#include "world/triangle_mesh.h"

#include <cstdint>
#include <functional>

namespace icube::render {

class OverlayWorld;

Trajectory lidar_ego_trajectory(const scene::Scene& s, const glm::dmat4& sensor_to_ego);

struct LidarSequenceStats {
  size_t frames = 0;
  uint64_t rays = 0, returns = 0;
  size_t max_overlay_bricks = 0, overlay_bytes = 0;
  // cars: voxelising dynamic cars; overlay: patching + uploading; upload: rays; cast: dispatch
  // (submit and wait); download: hits to the host; post: hits -> returns; sink: the callback.
  double cars_s = 0.0, overlay_s = 0.0, upload_s = 0.0, cast_s = 0.0, download_s = 0.0, post_s = 0.0, sink_s = 0.0;
};

struct LidarSequenceOptions {
  std::function<void(const LidarScan&)> on_frame;        // each scan, in trajectory order
  std::function<void(size_t done, size_t total)> progress;
};

// `scene` may be null (no dynamic cars). `world` holds the static scene.
LidarSequenceStats cast_lidar_sequence(gpu::Context& ctx, OverlayWorld& world, const scene::Scene* scene,
                                       const world::TriangleMesh& mesh, const LidarModel& model,
                                       const Trajectory& traj, const LidarSequenceOptions& opts);

}  // namespace icube::render
