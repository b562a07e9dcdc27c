// Stage 3 over a frames folder; see lift_frames.h.
#include "lift/lift_frames.h"

#include "lift/sky_fit.h"
#include "render/buffers/dynamic_cars.h"
#include "render/buffers/overlay_world.h"
#include "render/raycast_gpu.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/png_read.h"
#include "splat/rasterizer_gpu.h"
#include "splat/splat_scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>

namespace icube::lift {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

double LiftFramesResult::mean_psnr() const {
  if (eval.empty()) return 0.0;
  double s = 0.0;
  for (const EvalFrame& e : eval) s += e.psnr;
  return s / double(eval.size());
}

size_t LiftFramesResult::object_gaussians() const {
  size_t n = 0;
  for (const splat::SplatObject& o : objects) n += o.gaussians.size();
  return n;
}

render::Camera frame_camera(const render::FramesMeta& meta, size_t frame) {
  render::Camera cam;
  cam.K = meta.K;
  cam.c2w = meta.poses.at(frame);
  return cam;
}

bool splat_frames_are_times(const render::FramesMeta& meta) {
  if (meta.source_time_indices.size() != meta.poses.size() || meta.poses.empty()) return false;
  for (int t : meta.source_time_indices)
    if (t < 0) return false;
  return true;
}

size_t splat_frame_of(const render::FramesMeta& meta, size_t frame) {
  return splat_frames_are_times(meta) ? size_t(meta.source_time_indices.at(frame)) : frame;
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

  // The frames' scene: the static world on the GPU once, with the cars of each key frame's time
  // index patched in when there is a scene (as the frames were rendered).
  if (o.scene && !o.car_mesh) throw std::invalid_argument("lift_frames: a scene needs the cars' mesh");
  render::OverlayWorld overlay(ctx, static_world);
  std::optional<render::DynamicCarOverlay> cars;
  if (o.scene) cars.emplace(overlay, o.scene, *o.car_mesh);
  render::DynamicCarCosts car_costs;
  render::RaycasterGpu caster(ctx);
  render::RaycastOptions ro;
  ro.pixels = meta.pixels;
  StaticLiftAccumulator acc(static_world);
  DynamicLiftAccumulator dyn(o.dynamic);
  SkyFitter sky;
  splat::GaussianCloud pixel_cloud;
  const size_t first_pixel_key = res.key_frames.size() - std::min(o.pixel_frames, res.key_frames.size());
  auto time_index = [&](size_t f) { return f < meta.source_time_indices.size() ? meta.source_time_indices[f] : -1; };
  for (size_t k = 0; k < res.key_frames.size(); ++k) {
    const size_t f = res.key_frames[k];
    const FrameImages im = read_frame_images(frames_dir, meta, f);
    const render::Camera cam = frame_camera(meta, f);
    auto t0 = Clock::now();
    if (cars) cars->set_time(std::max(0, time_index(f)), car_costs);
    const std::vector<shader::RaycastHit> hits = caster.cast_camera(overlay.world(), cam, ro);
    res.cast_s += seconds_since(t0);
    t0 = Clock::now();
    res.samples += acc.add_frame(cam, meta.pixels, im.rgb, im.sky, im.instance, hits);
    res.sky_samples += sky.add_frame(cam, meta.pixels, im.rgb, im.sky);
    if (o.scene) {
      std::map<uint16_t, glm::dmat4> w2o = dynamic_object_poses(*o.scene, std::max(0, time_index(f)));
      for (auto& [id, m] : w2o) m = glm::inverse(m);
      res.dynamic_samples += dyn.add_frame(cam, meta.pixels, im.rgb, im.instance, hits, w2o);
    }
    if (k >= first_pixel_key)
      res.pixel += lift_midground_pixels(static_world, cam, meta.pixels, im.rgb, im.sky, im.instance, hits, pixel_cloud);
    res.accumulate_s += seconds_since(t0);
    if (o.progress) o.progress("lift", k + 1, res.key_frames.size());
  }
  auto t0 = Clock::now();
  LiftOptions lo = o.lift;
  if (lo.cameras.empty())
    for (const glm::dmat4& c2w : meta.poses) lo.cameras.emplace_back(c2w[3]);
  res.cloud = emit_static_gaussians(static_world, acc, lo, &res.stats);
  if (pixel_cloud.size() > 0) splat::append_cloud(res.cloud, pixel_cloud);
  res.sky = sky.image();
  // Splat-scene frames: every scene state (by time index) or the folder's frames (splat_frames_are_times).
  const bool by_time = splat_frames_are_times(meta);
  const size_t splat_frames = splat_frame_count(meta, o.scene);
  res.splat_frames = splat_frames;
  if (o.scene) {
    // Each object with its pose in every splat-scene frame where its track places it.
    std::map<uint16_t, std::vector<std::pair<size_t, glm::dmat4>>> tracks;
    for (size_t f = 0; f < splat_frames; ++f) {
      const int t = by_time ? int(f) : std::max(0, time_index(f));
      for (const auto& [id, m] : dynamic_object_poses(*o.scene, t)) tracks[id].emplace_back(f, m);
    }
    for (auto& [id, cloud] : dyn.emit()) {
      splat::SplatObject obj;
      obj.id = id;
      obj.source = "object_" + std::to_string(id) + ".ply";
      obj.gaussians = std::move(cloud);
      obj.poses.assign(splat_frames, glm::dmat4(1.0));
      obj.present.assign(splat_frames, 0);
      for (const auto& [f, m] : tracks[id]) obj.poses[f] = m, obj.present[f] = 1;
      res.objects.push_back(std::move(obj));
    }
  }
  res.emit_s = seconds_since(t0);

  evaluate_held_out_frames(ctx, frames_dir, meta, o.key_every, o.max_eval_frames, o.progress, res);
  return res;
}

size_t splat_frame_count(const render::FramesMeta& meta, const scene::Scene* scene) {
  size_t frames = meta.poses.size();
  if (splat_frames_are_times(meta) && scene) {
    frames = scene->timestamps.size();
    for (int t : meta.source_time_indices) frames = std::max(frames, size_t(t) + 1);
  }
  return frames;
}

void evaluate_held_out_frames(gpu::Context& ctx, const std::string& frames_dir, const render::FramesMeta& meta,
                              size_t key_every, size_t max_eval_frames,
                              const std::function<void(const char*, size_t, size_t)>& progress, LiftFramesResult& r) {
  const size_t n = meta.poses.size();
  std::vector<size_t> held;
  for (size_t f = 0; f < n; ++f)
    if (key_every == 1 || f % key_every != 0) held.push_back(f);
  std::vector<size_t> pick;
  const size_t m = std::min(max_eval_frames, held.size());
  for (size_t i = 0; i < m; ++i) pick.push_back(held[(2 * i + 1) * held.size() / (2 * m)]);
  if (pick.empty() || r.cloud.size() == 0) return;
  const auto t0 = Clock::now();
  splat::SplatScene placed;
  placed.static_set = r.cloud;
  placed.objects = r.objects;
  placed.frame_count = r.splat_frames;
  HeldOutRenderer renderer(ctx, placed, r.sky, meta.pixels);
  for (size_t i = 0; i < pick.size(); ++i) {
    r.eval.push_back(renderer.evaluate(frames_dir, meta, pick[i]));
    if (progress) progress("eval", i + 1, pick.size());
  }
  r.eval_s = seconds_since(t0);
}

}  // namespace icube::lift
