// icube-bench-lift: Stage 3 lifting (engine/lift/) on the demo town — the
// Gaussian density and shape knobs against held-out quality and time, side by
// side in one run. The frames: the procedural appearance renderer at 832 x 480
// (waymo-front-480p) along the ego drive, frames 20:60:2 (20 frames, key
// frames every 2nd: 10 key, 10 held out). Per variant: the lift itself (GPU
// camera casts of the key frames, accumulation, Gaussian emission; PNG reads
// included) timed over the runs, Gaussians per second of lifting, then the
// Gaussians (static set + the moving cars placed at the frame) rendered by the
// GPU splatting rasterizer at 4 held-out frames: render time per frame, PSNR
// over the static pixels and over the moving cars' pixels; the stale-view
// baseline (the previous key frame's image as the held-out frame) in the same
// table. Correctness check in the same run: every variant beats the baseline.
//
//   LP_NUM_THREADS=2 build/icube-bench-lift [--runs 5] [--warmup 1] [--frames 20:60:2]
#include "bench_stats.h"
#include "bench_worlds.h"

#include "gpu/context.h"
#include "lift/image_metrics.h"
#include "lift/lift_frames.h"
#include "render/appearance/frames_render.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"
#include "render/buffers/trajectory.h"
#include "world/car_mesh.h"
#include "world/demo_scene.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <unistd.h>
#include <vector>

using namespace icube;
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

struct Variant {
  std::string name;
  lift::LiftOptions o;
};

// PSNR of the previous key frame's image as the held-out frame, over its static pixels.
double stale_view_psnr(const std::string& dir, const render::FramesMeta& meta, size_t f) {
  const lift::FrameImages ref = lift::read_frame_images(dir, meta, f), key = lift::read_frame_images(dir, meta, f - 1);
  std::vector<uint8_t> static_px(ref.instance.size());
  for (size_t p = 0; p < static_px.size(); ++p) static_px[p] = ref.instance[p] < lift::kDynamicInstanceMin;
  return lift::psnr_rgb8(ref.rgb, key.rgb, static_px);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"icube-bench-lift: Stage 3 lifting, Gaussian density against held-out PSNR and time"};
  int runs = 5, warmup = 1;
  std::string frames = "20:60:2";
  app.add_option("--runs", runs, "Timed lifts per variant (min 5 for the tables)")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--warmup", warmup, "Untimed lifts first")->capture_default_str();
  app.add_option("--frames", frames, "Frames of the ego drive (A:B:S)")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    gpu::Context ctx(gpu::ContextOptions::from_env());
    std::printf("icube-bench-lift: device %s, LP_NUM_THREADS=%s\n", ctx.info().name.c_str(),
                std::getenv("LP_NUM_THREADS") ? std::getenv("LP_NUM_THREADS") : "(unset)");
    const scene::Scene sc = world::make_demo_scene();
    double build_s = 0.0;
    const world::VoxelGrid w = bench::build_procedural(sc, world::PlanMode::Trajectory, build_s);
    const scene::Camera preset = render::camera_preset("waymo-front-480p");
    const render::Trajectory tr = render::select_frames(render::ego_trajectory(sc, preset), render::parse_frame_range(frames));
    const world::TriangleMesh mesh = world::builtin_car_mesh();
    const world::VoxelGrid stat = render::make_static_world(w, sc, std::max(0, tr.time_index.at(0)), mesh);
    const fs::path dir = fs::temp_directory_path() / ("icube-bench-lift-" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    {
      render::OverlayWorld overlay(ctx, stat);
      render::FramesRenderOptions fo;
      render::render_frames(ctx, overlay, stat, &sc, mesh, render::intrinsics_of(preset), tr,
                            "The video is about a driving scene captured at daytime. The weather is clear.", fo,
                            dir.string());
    }
    const render::FramesMeta meta = render::read_frames_meta(dir.string());
    std::printf("demo town: %zu frames %ux%u (%s), key frames every 2nd\n\n", meta.poses.size(), meta.width,
                meta.height, frames.c_str());

    std::vector<Variant> variants;
    auto add = [&](const std::string& name, int per_cell, float sigma, bool face, bool hidden) {
      Variant v{name, {}};
      v.o.per_cell = per_cell;
      v.o.cell_sigma = sigma;
      v.o.face_gaussians = face;
      v.o.hidden = hidden;
      variants.push_back(v);
    };
    add("one per face (0.2 m)", 1, 0.4f, true, true);
    add("1 per cell, sigma 0.3", 1, 0.3f, false, true);
    add("1 per cell, sigma 0.4 (default)", 1, 0.4f, false, true);
    add("1 per cell, sigma 0.6", 1, 0.6f, false, true);
    add("1 per cell, no hidden voxels", 1, 0.4f, false, false);
    add("4 per cell (official density), sigma 0.4", 4, 0.4f, false, true);

    std::printf("%-42s %10s %9s %9s %12s %10s %9s %16s %9s\n", "variant", "Gaussians", "lift min", "lift med",
                "Gaussians/s", "render ms", "PSNR dB", "objects (Gauss.)", "dyn. dB");
    bool ok = true;
    double baseline = 0.0;
    for (const Variant& v : variants) {
      lift::LiftFramesOptions o;
      o.lift = v.o;
      o.key_every = 2;
      o.max_eval_frames = 0;
      o.scene = &sc;
      o.car_mesh = &mesh;
      std::vector<double> ms;
      size_t count = 0;
      for (int i = 0; i < warmup + runs; ++i) {
        const auto t0 = Clock::now();
        const lift::LiftFramesResult r = lift::lift_frames(ctx, stat, dir.string(), meta, o);
        if (i >= warmup) ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        count = r.cloud.size();
      }
      o.max_eval_frames = 4;
      const lift::LiftFramesResult r = lift::lift_frames(ctx, stat, dir.string(), meta, o);
      double render_ms = 0.0;
      for (const lift::EvalFrame& e : r.eval) render_ms += 1000.0 * e.render_s;
      render_ms /= double(std::max<size_t>(1, r.eval.size()));
      if (baseline == 0.0) {
        for (const lift::EvalFrame& e : r.eval) baseline += stale_view_psnr(dir.string(), meta, e.frame);
        baseline /= double(std::max<size_t>(1, r.eval.size()));
      }
      const bench::Summary s = bench::summarize(ms);
      const bool beats = r.mean_psnr() > baseline;
      ok = ok && beats;
      size_t object_gaussians = 0, dyn_frames = 0;
      double dyn_psnr = 0.0;
      for (const auto& obj : r.objects) object_gaussians += obj.gaussians.size();
      for (const lift::EvalFrame& e : r.eval)
        if (e.dynamic_pixels > 0) dyn_psnr += e.psnr_dynamic, ++dyn_frames;
      char objs[32];
      std::snprintf(objs, sizeof objs, "%zu (%zu)", r.objects.size(), object_gaussians);
      std::printf("%-42s %10zu %9.0f %9.0f %12.3g %10.1f %9.2f %16s %9.2f%s\n", v.name.c_str(), count, s.min_ms,
                  s.median_ms, double(count) / (s.median_ms / 1000.0), render_ms, r.mean_psnr(), objs,
                  dyn_frames ? dyn_psnr / double(dyn_frames) : 0.0, beats ? "" : " FAIL");
    }
    std::printf("%-42s %10s %9s %9s %12s %10s %9.2f\n", "stale view (previous key frame)", "-", "-", "-", "-", "-",
                baseline);
    fs::remove_all(dir);
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-bench-lift: %s\n", e.what());
    return 1;
  }
}
