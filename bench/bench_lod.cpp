// icube-bench-lod: level of detail of a package's static Gaussians
// (splat/gaussian_lod.h) — chunk culling by frustum and distance and the
// coarse merged level — against image quality and frame time, side by side
// in one run. Per setting and per frame (frames not used for lifting, spread
// evenly): the selection (CPU), compose + upload (the objects placed at the
// frame), the GPU render; min and median over the runs; PSNR and SSIM over
// the static pixels against the appearance frame, and the PSNR against the
// whole set's render (the LOD error alone). Correctness check in the same
// run: frustum culling alone must render the whole set's image (>= 60 dB).
//
//   LP_NUM_THREADS=2 build/icube-bench-lod --package build/demo/package [--frames 4] [--runs 5] [--warmup 1] [--scale S] [--key-bits 16]
// The last columns: the median GPU time of each rasterizer phase. --scale renders the same
// views smaller (the viewer's adaptive resolution; no quality columns then).
//
// The package comes from `tools/quickstart demo` (or `icube generate`).
#include "bench_stats.h"

#include "gpu/context.h"
#include "lift/image_metrics.h"
#include "lift/lift_frames.h"
#include "render/appearance/frames_layout.h"
#include "scene/atomic_file.h"
#include "scene/package_layout.h"
#include "splat/gaussian_lod.h"
#include "splat/rasterizer_gpu.h"
#include "splat/splat_scene.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

using namespace icube;
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

struct Setting {
  std::string name;
  bool chunked = true;
  splat::LodOptions lod;
};


// The settings compared, from the whole set to all-coarse.
std::vector<Setting> lod_settings() {
  std::vector<Setting> settings;
  auto add = [&](const std::string& name, bool chunked, bool frustum, double max_d, double coarse_d) {
    Setting s{name, chunked, {}};
    s.lod.frustum = frustum;
    s.lod.max_distance = max_d;
    s.lod.coarse_distance = coarse_d;
    settings.push_back(s);
  };
  add("whole set", false, false, 0, 0);
  add("frustum", true, true, 0, 0);
  add("frustum, <= 120 m", true, true, 120, 0);
  add("frustum, <= 80 m", true, true, 80, 0);
  add("frustum, coarse beyond 40 m", true, true, 0, 40);
  add("frustum, <= 80 m, coarse beyond 25 m", true, true, 80, 25);
  add("frustum, <= 60 m, coarse beyond 15 m", true, true, 60, 15);
  add("frustum, <= 80 m, coarse beyond 10 m", true, true, 80, 10);
  add("frustum, <= 80 m, coarse beyond 5 m", true, true, 80, 5);
  add("frustum, <= 80 m, all coarse", true, true, 80, 1e-3);
  return settings;
}

// Up to `frames` held-out frames (not key frames of the lift report), evenly spread.
std::vector<size_t> spread_heldout_frames(const scene::PackageLayout& pkg, size_t frame_count, size_t frames) {
  const auto report = nlohmann::json::parse(scene::read_file(pkg.lift_report().string()));
  std::set<size_t> keys;
  for (const auto& k : report["key_frames"]) keys.insert(k.get<size_t>());
  std::vector<size_t> held, pick;
  for (size_t f = 0; f < frame_count; ++f)
    if (!keys.count(f)) held.push_back(f);
  const size_t m = std::min(frames, held.size());
  for (size_t i = 0; i < m; ++i) pick.push_back(held[(2 * i + 1) * held.size() / (2 * m)]);
  return pick;
}

// The benchmark's inputs and options, and one row of the table per setting.
struct LodBench {
  int runs = 5, warmup = 1;
  double scale = 1.0;
  scene::PackageLayout pkg{""};
  render::FramesMeta meta;
  splat::SplatScene scene;
  splat::ChunkedGaussians chunks;
  std::vector<size_t> pick;
  std::vector<std::vector<uint8_t>> reference_whole;  // the whole set's render of each frame

  // Renders every picked frame with setting `s`, prints its row; false when its check fails.
  bool row(const Setting& s, splat::SplatRendererGpu& renderer, const splat::SplatOptions& so);
};

bool LodBench::row(const Setting& s, splat::SplatRendererGpu& renderer, const splat::SplatOptions& so) {
  const std::string frames_dir = pkg.frames().string();
  const size_t px = size_t(meta.width) * meta.height;
  std::vector<double> sel_ms, up_ms, render_ms, prep_ms, dsort_ms, bin_ms, blend_ms;
  double psnr = 0.0, ssim = 0.0, vs_whole = 0.0, gaussians = 0.0, chunks_drawn = 0.0;
  for (size_t i = 0; i < pick.size(); ++i) {
    const size_t f = pick[i];
    render::Camera cam = lift::frame_camera(meta, f);
    if (scale != 1.0) {  // the same view at a fraction of the size
      cam.K.fx *= scale;
      cam.K.fy *= scale;
      cam.K.cx *= scale;
      cam.K.cy *= scale;
      cam.K.width = uint32_t(std::lround(cam.K.width * scale));
      cam.K.height = uint32_t(std::lround(cam.K.height * scale));
    }
    auto t0 = Clock::now();
    splat::SplatScene part;
    part.objects = scene.objects;
    part.frame_count = scene.frame_count;
    if (s.chunked) {
      splat::LodSelection sel = splat::select_gaussians(chunks, cam, s.lod);
      chunks_drawn += double(sel.chunks_fine + sel.chunks_coarse);
      part.static_set = std::move(sel.cloud);
    } else {
      part.static_set = scene.static_set;
      chunks_drawn += double(chunks.chunks.size());
    }
    sel_ms.push_back(ms_since(t0));
    t0 = Clock::now();
    const splat::GaussianCloud cloud = splat::compose_frame(part, lift::splat_frame_of(meta, f));
    const splat::GpuGaussians g = renderer.upload(cloud);
    up_ms.push_back(ms_since(t0));
    gaussians += double(cloud.size());
    splat::SplatImage img;
    for (int r = 0; r < warmup + runs; ++r) {
      t0 = Clock::now();
      splat::SplatTimings tm;
      img = renderer.render(g, cam, so, &tm);
      if (r >= warmup) {
        render_ms.push_back(ms_since(t0));
        prep_ms.push_back(tm.preprocess_ms);
        dsort_ms.push_back(tm.depth_sort_ms);
        bin_ms.push_back(tm.sort_ms);
        blend_ms.push_back(tm.blend_ms);
      }
    }
    const std::vector<uint8_t> rgb = lift::splat_rgb8(img);
    if (scale != 1.0) continue;  // quality needs the frames' size
    const lift::FrameImages ref = lift::read_frame_images(frames_dir, meta, f);
    std::vector<uint8_t> mask(px);
    for (size_t p = 0; p < px; ++p) mask[p] = ref.instance[p] < lift::kDynamicInstanceMin;
    psnr += lift::psnr_rgb8(rgb, ref.rgb, mask);
    ssim += lift::ssim_rgb8(rgb, ref.rgb, meta.width, meta.height, mask);
    if (!s.chunked) reference_whole[i] = rgb;
    vs_whole += lift::psnr_rgb8(rgb, reference_whole[i]);
  }
  const double k = double(std::max<size_t>(1, pick.size()));
  const bench::Summary rs = bench::summarize(render_ms), ss = bench::summarize(sel_ms), us = bench::summarize(up_ms);
  const bool check = s.chunked && !s.lod.max_distance && !s.lod.coarse_distance ? vs_whole / k >= 60.0 : true;
  auto med = [](const std::vector<double>& v) { return bench::summarize(v).median_ms; };
  std::printf("%-38s %10.0f %8.0f %10.1f %10.1f %10.1f %10.1f %8.2f %7.4f %9.2f %7.1f %7.1f %7.1f %7.1f%s\n",
              s.name.c_str(), gaussians / k, chunks_drawn / k, ss.median_ms, us.median_ms, rs.min_ms, rs.median_ms,
              psnr / k, ssim / k, vs_whole / k, med(prep_ms), med(dsort_ms), med(bin_ms), med(blend_ms),
              check ? "" : " FAIL");
  return check;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"icube-bench-lod: level of detail of a package's Gaussians against quality and frame time"};
  LodBench b;
  std::string package;
  size_t frames = 4;
  app.add_option("--package", package, "Package folder (tools/quickstart demo writes build/demo/package)")->required();
  app.add_option("--frames", frames, "Held-out frames rendered per setting")->capture_default_str();
  app.add_option("--runs", b.runs, "Timed renders per frame")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--warmup", b.warmup, "Untimed renders first")->capture_default_str();
  uint32_t key_bits = 32;
  app.add_option("--key-bits", key_bits, "Depth sort keys: 32 (exact) or 16 (SplatOptions::depth_key_bits)")
      ->capture_default_str()
      ->check(CLI::IsMember({16, 32}));
  app.add_option("--scale", b.scale, "Render at this fraction of the frames' size (quality columns need 1)")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 1.0));
  CLI11_PARSE(app, argc, argv);
  try {
    b.pkg = scene::PackageLayout(package);
    if (!fs::is_regular_file(b.pkg.manifest())) {
      std::fprintf(stderr, "icube-bench-lod: %s is not a package (run tools/quickstart demo first)\n", package.c_str());
      return 2;
    }
    gpu::Context ctx(gpu::ContextOptions::from_env());
    std::printf("icube-bench-lod: device %s, LP_NUM_THREADS=%s\n", ctx.info().name.c_str(),
                std::getenv("LP_NUM_THREADS") ? std::getenv("LP_NUM_THREADS") : "(unset)");
    b.meta = render::read_frames_meta(b.pkg.frames().string());
    b.scene = splat::read_splat_scene(b.pkg.splat_scene().string());
    b.pick = spread_heldout_frames(b.pkg, b.meta.poses.size(), frames);
    b.reference_whole.resize(b.pick.size());
    const auto t0 = Clock::now();
    b.chunks = splat::build_gaussian_chunks(b.scene.static_set);
    std::printf("%s: %zu static Gaussians, %zu objects; %zu chunks of %.1f m, coarse level %zu Gaussians (merge cell "
                "%.1f m), built in %.0f ms; %zu frames %ux%u\n\n",
                package.c_str(), b.scene.static_set.size(), b.scene.objects.size(), b.chunks.chunks.size(),
                b.chunks.options.chunk_size, b.chunks.coarse.size(), b.chunks.options.merge_cell, ms_since(t0), b.pick.size(),
                b.meta.width, b.meta.height);

    splat::SplatRendererGpu renderer(ctx);
    splat::SplatOptions so;
    so.pixels = b.meta.pixels;
    so.depth = false;
    so.depth_key_bits = key_bits;
    so.sky = splat::sky_equirect(std::make_shared<const splat::SkyImage>(splat::read_sky_png(b.pkg.sky().string())));
    std::printf("%-38s %10s %8s %10s %10s %10s %10s %8s %7s %9s %7s %7s %7s %7s\n", "setting", "Gaussians", "chunks",
                "select ms", "upload ms", "render min", "render med", "PSNR dB", "SSIM", "vs whole", "prep", "dsort",
                "bin", "blend");
    bool ok = true;
    for (const Setting& s : lod_settings()) ok = b.row(s, renderer, so) && ok;
    std::printf("\n(Gaussians, chunks: mean per frame; select, upload: median per frame; render: over %d runs x %zu "
                "frames; PSNR/SSIM over static pixels vs the appearance frames; vs whole: PSNR against the whole set's "
                "render, 99 = identical)\n",
                b.runs, b.pick.size());
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-bench-lod: %s\n", e.what());
    return 1;
  }
}
