// Stage 3 over an appearance-frames folder (render/appearance/frames_layout.h):
// the static Gaussians and the sky lifted from the key frames (static_lift.h,
// sky_fit.h; the per-pixel first hits from the GPU ray caster on the static
// world the frames were rendered from), and the held-out evaluation: the
// Gaussians rendered by the GPU splatting rasterizer with the fitted sky at
// frames not used for lifting, against those frames, as PSNR over the pixels
// that are not dynamic objects (instance < 10000) and, with a scene, over the
// dynamic objects' pixels with the objects placed at the frame's poses.
// Key frames: every `key_every`-th frame from 0; held-out frames: the others,
// or all frames with key_every 1 (then the figures are training-view figures).
// Tests: tests/lift/test_static_lift.cpp.
#pragma once

#include "gpu/context.h"
#include "lift/dynamic_lift.h"
#include "lift/heldout_render.h"
#include "lift/pixel_branch.h"
#include "lift/static_lift.h"
#include "render/appearance/frames_layout.h"
#include "world/triangle_mesh.h"
#include "splat/sky.h"

#include <functional>
#include <string>
#include <vector>

namespace icube::lift {

struct LiftFramesOptions {
  LiftOptions lift;
  // The scene the frames were rendered with: its dynamic vehicles are cast at each key frame's
  // time index (the static world + the frame's cars, as the frames were rendered) and lifted
  // into their object frames (dynamic_lift.h). Null: static only. car_mesh: the cars' mesh.
  const scene::Scene* scene = nullptr;
  const world::TriangleMesh* car_mesh = nullptr;
  DynamicLiftOptions dynamic;
  size_t key_every = 2;
  // Pixel branch (pixel_branch.h): the mid-ground pixels of the last `pixel_frames` key frames
  // (the official default is the last 1; 0 = off). Needs sky masks from the frames themselves.
  size_t pixel_frames = 1;
  size_t max_eval_frames = 4;  // held-out frames rendered for the figures (evenly spread)
  std::function<void(const char* stage, size_t done, size_t total)> progress;
};

struct LiftFramesResult {
  splat::GaussianCloud cloud;                // the static set (world frame): voxel branch, then pixel branch
  std::vector<splat::SplatObject> objects;   // dynamic objects (object frames), poses per splat-scene frame
  size_t splat_frames = 0;                   // frames of the splat scene (splat_frames_are_times)
  splat::SkyImage sky;
  LiftStats stats;
  PixelBranchStats pixel;                    // the pixel branch's part (appended to `cloud`)
  std::vector<size_t> key_frames;
  size_t samples = 0, sky_samples = 0, dynamic_samples = 0;
  double cast_s = 0.0, accumulate_s = 0.0, emit_s = 0.0, eval_s = 0.0;
  std::vector<EvalFrame> eval;
  double mean_psnr() const;
  size_t object_gaussians() const;  // over every dynamic object
};

// The frames' images as the lifting reads them.
struct FrameImages {
  std::vector<uint8_t> rgb, sky;
  std::vector<uint16_t> instance;
};
FrameImages read_frame_images(const std::string& dir, const render::FramesMeta& meta, size_t frame);

render::Camera frame_camera(const render::FramesMeta& meta, size_t frame);

// The frames of a lifted splat scene (scene.json): the scene's time indices when every frame of the
// folder has one (the dynamic objects' tracks then cover every scene state, so `icube lidar
// --gaussians --scene` and a trajectory's time_indices place them as the guidance buffers do),
// else the folder's frame numbers. splat_frame_of gives folder frame f's frame in the splat scene.
bool splat_frames_are_times(const render::FramesMeta& meta);
size_t splat_frame_of(const render::FramesMeta& meta, size_t frame);
// The splat scene's frame count: every state of `scene` (and every time index of the folder) when the frames
// are times, else the folder's frames.
size_t splat_frame_count(const render::FramesMeta& meta, const scene::Scene* scene);

LiftFramesResult lift_frames(gpu::Context& ctx, const world::VoxelGrid& static_world, const std::string& frames_dir,
                             const render::FramesMeta& meta, const LiftFramesOptions& o);

// The held-out figures of a lift (both lifts' last step): up to max_eval_frames of the frames that are not
// key frames (every key_every-th from 0), evenly spread, rendered from r's Gaussians, objects and sky into
// r.eval (and r.eval_s); nothing without Gaussians. progress("eval", done, total) after each frame.
void evaluate_held_out_frames(gpu::Context& ctx, const std::string& frames_dir, const render::FramesMeta& meta,
                              size_t key_every, size_t max_eval_frames,
                              const std::function<void(const char*, size_t, size_t)>& progress, LiftFramesResult& r);

}  // namespace icube::lift
