// Rendering a trajectory into guidance frames (Stage 2, conventions §10):
// the static scene on the GPU once (OverlayWorld), each frame's dynamic cars
// patched in, one RaycasterGpu camera dispatch per frame (first-hit 1 cm for
// semantics, 0.1 m runs for depth, InfiniCube integer-pixel rays unless
// `pixels` says pixel centres), then the sequence-wide parts: instance colours
// (unique instance ids over all frames, seeded PuRd) and the coordinate-buffer
// range (quantiles over 100,000 seeded samples of all frames, in the first
// camera's OpenCV frame).
// Frames are kept in memory (7 bytes per pixel, + 1 with normals): 832x480 x
// 200 frames is about 560 MB.
#pragma once

#include "render/buffers/coordinate_buffer.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/guidance_frame.h"
#include "render/buffers/instance_colors.h"
#include "render/buffers/trajectory.h"
#include "render/raycast_gpu.h"

#include <cstdint>
#include <functional>
#include <map>
#include <vector>

namespace icube::render {

class OverlayWorld;

struct SequenceOptions {
  PixelConvention pixels = PixelConvention::Integer;
  uint64_t seed = 0;
  bool keep_normals = false;
  std::function<void(size_t done, size_t total)> progress;
};

struct GuidanceSequence {
  PinholeIntrinsics K;
  Trajectory trajectory;                 // our world frame
  std::vector<GuidanceFrame> frames;
  std::vector<glm::dmat4> rel;           // inv(pose_0) · pose_i
  std::map<uint16_t, Rgb8> instance_colors;
  CoordinateRange coordinates;
  PixelConvention pixels = PixelConvention::Integer;
  // Timings and counts.
  uint64_t rays = 0;
  // cars: voxelising dynamic cars; overlay: patching + uploading; cast: the ray-cast
  // dispatch (submit and wait); download: hits to the host; post: hits -> frames + sequence-wide parts.
  double cars_s = 0.0, overlay_s = 0.0, cast_s = 0.0, download_s = 0.0, post_s = 0.0;
  size_t max_overlay_bricks = 0, overlay_bytes = 0;
};

// `scene` may be null (no dynamic cars). `world` holds the static scene (make_static_world).
GuidanceSequence render_sequence(gpu::Context& ctx, OverlayWorld& world, const scene::Scene* scene,
                                 const world::TriangleMesh& mesh, const PinholeIntrinsics& K, const Trajectory& traj,
                                 const SequenceOptions& opts);

}  // namespace icube::render
