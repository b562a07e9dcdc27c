// A package's preview of its Gaussians: the static set (through the level of
// detail of splat/gaussian_lod.h), the moving cars placed at each frame and
// the fitted sky, rendered by the GPU splatting rasterizer at every frame of
// the trajectory, written as flythrough.mp4 (H.264, engine/video, 10 fps;
// optional) and flythrough.png: up to `sheet_frames` frames spread evenly,
// the appearance frame above the Gaussians' render, at half size. Files written
// atomically. Used by `icube generate` (the package's preview/).
// Tests: tests/lift/test_generate.cpp.
#pragma once

#include "gpu/context.h"
#include "render/appearance/frames_layout.h"
#include "splat/gaussian_lod.h"
#include "splat/sky.h"
#include "splat/splat_scene.h"
#include "video/mp4_writer.h"

#include <functional>
#include <string>

namespace icube::lift {

struct FlythroughOptions {
  splat::LodOptions lod = [] {
    splat::LodOptions o;
    o.max_distance = 80.0;     // 0.2 dB against the frames on the demo town for 2x the speed of the
    o.coarse_distance = 25.0;  // frustum-culled set (docs/stage3-lifting.md, "Level of detail")
    return o;
  }();
  bool video = true;
  video::Mp4Options mp4;
  size_t sheet_frames = 6;
  std::function<void(size_t done, size_t total)> progress;
};

struct FlythroughResult {
  size_t frames = 0;
  double mean_gaussians = 0.0;  // drawn per frame
  double render_s = 0.0;        // selection, upload and render, all frames
};

FlythroughResult write_flythrough(gpu::Context& ctx, const splat::SplatScene& scene, const splat::SkyImage& sky,
                                  const render::FramesMeta& meta, const std::string& frames_dir, const std::string& dir,
                                  const FlythroughOptions& o);

}  // namespace icube::lift
