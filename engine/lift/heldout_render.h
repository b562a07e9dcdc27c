// A lifted scene (static Gaussians, dynamic objects with per-frame poses, the
// fitted sky) rendered by the GPU splatting rasterizer at frames of an
// appearance-frames folder and compared with those frames: PSNR over the
// static pixels (instance < 10000), PSNR over the dynamic objects' pixels
// (with the objects placed at the frame's poses), SSIM (image_metrics.h)
// over the windows centred on static pixels. Used for the held-out figures of
// lift_frames and by `icube eval` (package_eval.h).
// Tests: tests/lift/test_static_lift.cpp, tests/lift/test_package_eval.cpp.
#pragma once

#include "gpu/context.h"
#include "render/appearance/frames_layout.h"
#include "splat/lod_gaussians_gpu.h"
#include "splat/rasterizer_gpu.h"
#include "splat/splat_scene.h"
#include "splat/sky.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace icube::lift {

struct EvalFrame {
  size_t frame = 0;
  double psnr = 0.0;       // dB over the static pixels (instance < 10000)
  double mse = 0.0;        // mean squared error in [0, 1] units over the same pixels
  double ssim = 0.0;       // over the windows centred on static pixels
  size_t pixels = 0;
  double psnr_dynamic = 0.0;  // dB over the dynamic objects' pixels (0 when there are none)
  size_t dynamic_pixels = 0;
  double render_s = 0.0;   // GPU render of the frame (upload excluded)
  std::vector<uint8_t> rendered_rgb;   // W·H·3
  std::vector<uint8_t> reference_rgb;  // W·H·3, the frame it was compared with
};

class HeldOutRenderer {
 public:
  // `scene` and `sky` are copied; a folder frame f shows the objects at splat_frame_of(meta, f) (lift_frames.h).
  HeldOutRenderer(gpu::Context& ctx, const splat::SplatScene& scene, const splat::SkyImage& sky,
                  render::PixelConvention pixels);
  EvalFrame evaluate(const std::string& frames_dir, const render::FramesMeta& meta, size_t frame);

 private:
  splat::SplatRendererGpu renderer_;
  std::vector<splat::SplatObject> objects_;
  splat::SplatOptions options_;
  // The static set resident once, in its order; each frame uploads only the placed objects behind it.
  std::unique_ptr<splat::LodGaussiansGpu> static_gpu_;
};

// A render as RGB8 (splat::splat_channel8: clamped to [0, 1], rounded, NaN -> 0; as the GPU's
// splat/to_rgba8.comp), W·H·3.
std::vector<uint8_t> splat_rgb8(const splat::SplatImage& img);

// PSNR (dB) from a mean squared error in [0, 1] units (99 dB for a zero error).
double psnr_from_mse(double mse);

}  // namespace icube::lift
