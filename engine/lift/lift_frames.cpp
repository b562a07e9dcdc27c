// Stage 3 over a frames folder; see lift_frames.h.
#include "lift/lift_frames.h"

#include "lift/sky_fit.h"
#include "render/raycast_gpu.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/png_read.h"
#include "splat/rasterizer_gpu.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>

namespace icube::lift {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

double psnr_from_mse(double mse) { return mse > 0.0 ? -10.0 * std::log10(mse) : 99.0; }

double LiftFramesResult::mean_psnr() const {
  if (eval.empty()) return 0.0;
  double s = 0.0;
  for (const EvalFrame& e : eval) s += e.psnr;
  return s / double(eval.size());
}

render::Camera frame_camera(const render::FramesMeta& meta, size_t frame) {
  render::Camera cam;
  cam.K = meta.K;
  cam.c2w = meta.poses.at(frame);
  return cam;
}

FrameImages read_frame_images(const std::string& dir, const render::FramesMeta& meta, size_t frame) {
  const std::string name = render::frame_file_name(frame);
  FrameImages im;
  const std::string rgb_path = (fs::path(dir) / "rgb" / name).string();
  const scene::Image8 rgb = scene::read_png(rgb_path, 3);
  const std::string sky_path = (fs::path(dir) / "sky_mask" / name).string();
  const scene::Image8 sky = scene::read_png(sky_path, 1);
  const std::string inst_path = (fs::path(dir) / "instance" / name).string();
  int iw = 0, ih = 0;
  im.instance = scene::decode_png_gray16(scene::read_file(inst_path), inst_path, &iw, &ih);
  auto check = [&](const std::string& path, int w, int h) {
    if (uint32_t(w) != meta.width || uint32_t(h) != meta.height)
      throw scene::InputError(path, "", std::to_string(w) + "x" + std::to_string(h) + " but frames_meta.json says " +
                                            std::to_string(meta.width) + "x" + std::to_string(meta.height));
  };
  check(rgb_path, rgb.width, rgb.height);
  check(sky_path, sky.width, sky.height);
  check(inst_path, iw, ih);
  im.rgb = rgb.pixels;
  im.sky = sky.pixels;
  return im;
}

LiftFramesResult lift_frames(gpu::Context& ctx, const world::VoxelGrid& static_world, const std::string& frames_dir,
                             const render::FramesMeta& meta, const LiftFramesOptions& o) {
  if (o.key_every == 0) throw std::invalid_argument("key_every must be at least 1");
  const size_t n = meta.poses.size();
  if (n == 0) throw scene::InputError(frames_dir + "/frames_meta.json", "/count", "no frames to lift");
  LiftFramesResult res;
  for (size_t f = 0; f < n; f += o.key_every) res.key_frames.push_back(f);

  const render::RaycastWorld rw = render::upload_raycast_world(ctx, static_world);
  render::RaycasterGpu caster(ctx);
  render::RaycastOptions ro;
  ro.pixels = meta.pixels;
  StaticLiftAccumulator acc(static_world);
  SkyFitter sky;
  for (size_t k = 0; k < res.key_frames.size(); ++k) {
    const size_t f = res.key_frames[k];
    const FrameImages im = read_frame_images(frames_dir, meta, f);
    const render::Camera cam = frame_camera(meta, f);
    auto t0 = Clock::now();
    const std::vector<shader::RaycastHit> hits = caster.cast_camera(rw, cam, ro);
    res.cast_s += seconds_since(t0);
    t0 = Clock::now();
    res.samples += acc.add_frame(cam, meta.pixels, im.rgb, im.sky, im.instance, hits);
    res.sky_samples += sky.add_frame(cam, meta.pixels, im.rgb, im.sky);
    res.accumulate_s += seconds_since(t0);
    if (o.progress) o.progress("lift", k + 1, res.key_frames.size());
  }
  auto t0 = Clock::now();
  LiftOptions lo = o.lift;
  if (lo.cameras.empty())
    for (const glm::dmat4& c2w : meta.poses) lo.cameras.emplace_back(c2w[3]);
  res.cloud = emit_static_gaussians(static_world, acc, lo, &res.stats);
  res.sky = sky.image();
  res.emit_s = seconds_since(t0);

  // Held-out frames, evenly spread.
  std::vector<size_t> held;
  for (size_t f = 0; f < n; ++f)
    if (o.key_every == 1 || f % o.key_every != 0) held.push_back(f);
  std::vector<size_t> pick;
  const size_t m = std::min(o.max_eval_frames, held.size());
  for (size_t i = 0; i < m; ++i) pick.push_back(held[(2 * i + 1) * held.size() / (2 * m)]);
  if (pick.empty() || res.cloud.size() == 0) return res;
  t0 = Clock::now();
  splat::SplatRendererGpu renderer(ctx);
  const splat::GpuGaussians g = renderer.upload(res.cloud);
  splat::SplatOptions so;
  so.pixels = meta.pixels;
  so.depth = false;
  so.sky = splat::sky_equirect(std::make_shared<const splat::SkyImage>(res.sky));
  for (size_t i = 0; i < pick.size(); ++i) {
    const size_t f = pick[i];
    const FrameImages im = read_frame_images(frames_dir, meta, f);
    EvalFrame e;
    e.frame = f;
    const auto tr = Clock::now();
    const splat::SplatImage img = renderer.render(g, frame_camera(meta, f), so);
    e.render_s = seconds_since(tr);
    const size_t px = size_t(meta.width) * meta.height;
    e.rendered_rgb.resize(px * 3);
    double se = 0.0;
    for (size_t p = 0; p < px; ++p)
      for (int c = 0; c < 3; ++c) {
        const double v = std::clamp(double(img.rgba[4 * p + size_t(c)]), 0.0, 1.0);
        e.rendered_rgb[3 * p + size_t(c)] = static_cast<uint8_t>(std::lround(v * 255.0));
        if (im.instance[p] >= kDynamicInstanceMin) continue;
        const double d = v - double(im.rgb[3 * p + size_t(c)]) / 255.0;
        se += d * d;
        if (c == 0) ++e.pixels;
      }
    e.mse = e.pixels > 0 ? se / (3.0 * double(e.pixels)) : 0.0;
    e.psnr = psnr_from_mse(e.mse);
    res.eval.push_back(std::move(e));
    if (o.progress) o.progress("eval", i + 1, pick.size());
  }
  res.eval_s = seconds_since(t0);
  return res;
}

}  // namespace icube::lift
