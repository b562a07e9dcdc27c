#include "lift/heldout_render.h"

#include "splat/splat_rgba8.h"

#include "lift/dynamic_lift.h"
#include "lift/image_metrics.h"
#include "lift/lift_frames.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace icube::lift {

std::vector<uint8_t> splat_rgb8(const splat::SplatImage& img) {
  std::vector<uint8_t> rgb(img.rgba.size() / 4 * 3);
  for (size_t p = 0; p < rgb.size() / 3; ++p)
    for (size_t c = 0; c < 3; ++c)
      rgb[3 * p + c] = splat::splat_channel8(img.rgba[4 * p + c]);
  return rgb;
}

double psnr_from_mse(double mse) { return mse > 0.0 ? -10.0 * std::log10(mse) : 99.0; }

HeldOutRenderer::HeldOutRenderer(gpu::Context& ctx, const splat::SplatScene& scene, const splat::SkyImage& sky,
                                 render::PixelConvention pixels)
    : renderer_(ctx), objects_(scene.objects) {
  options_.pixels = pixels;
  options_.depth = false;
  options_.sky = splat::sky_equirect(std::make_shared<const splat::SkyImage>(sky));
  static_gpu_ =
      std::make_unique<splat::LodGaussiansGpu>(ctx, splat::single_chunk(scene.static_set), splat::max_sh_degree(scene));
}

EvalFrame HeldOutRenderer::evaluate(const std::string& frames_dir, const render::FramesMeta& meta, size_t frame) {
  const FrameImages im = read_frame_images(frames_dir, meta, frame);
  EvalFrame e;
  e.frame = frame;
  static_gpu_->set_extra(splat::compose_objects(objects_, splat_frame_of(meta, frame), static_gpu_->sh_degree()));
  const splat::GpuGaussians& g = static_gpu_->assemble({splat::ChunkPick{0, false}});
  const auto t0 = std::chrono::steady_clock::now();
  const splat::SplatImage img = renderer_.render(g, frame_camera(meta, frame), options_);
  e.render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const size_t px = size_t(meta.width) * meta.height;
  e.rendered_rgb = splat_rgb8(img);
  std::vector<uint8_t> static_mask(px);
  double se = 0.0, se_dyn = 0.0;
  for (size_t p = 0; p < px; ++p) {
    const bool dynamic = im.instance[p] >= kDynamicInstanceMin;
    static_mask[p] = dynamic ? 0 : 1;
    for (int c = 0; c < 3; ++c) {
      const double v = std::clamp(double(img.rgba[4 * p + size_t(c)]), 0.0, 1.0);
      const double d = v - double(im.rgb[3 * p + size_t(c)]) / 255.0;
      (dynamic ? se_dyn : se) += d * d;
    }
    ++(dynamic ? e.dynamic_pixels : e.pixels);
  }
  e.mse = e.pixels > 0 ? se / (3.0 * double(e.pixels)) : 0.0;
  e.psnr = psnr_from_mse(e.mse);
  if (!objects_.empty() && e.dynamic_pixels > 0)
    e.psnr_dynamic = psnr_from_mse(se_dyn / (3.0 * double(e.dynamic_pixels)));
  e.ssim = ssim_rgb8(e.rendered_rgb, im.rgb, meta.width, meta.height, static_mask);
  e.reference_rgb = im.rgb;
  return e;
}

}  // namespace icube::lift
