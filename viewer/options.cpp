// icube-view's command line; see options.h.
#include "options.h"

#include "scene/png_read.h"
#include "scene/frames.h"
#include "screenshot_check.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>

namespace icube::viewer {

int parse_options(int argc, char** argv, Options& o) {
  CLI::App app{"InfiniCube-VK viewer: drive or fly through a voxel world or a package's Gaussians, record and replay "
               "camera trajectories",
               "icube-view"};
  app.add_option("input", o.input,
                 "World file (.icw), a folder holding world.icw (+ scene.json), an icube generate package (its "
                 "Gaussians too), or Gaussians alone (a splat scene .json, a 3DGS .ply or .splat)");
  app.add_option("--view", o.view, "Start with the voxel or the Gaussian view (auto: Gaussians when the input has them)")
      ->check(CLI::IsMember({"auto", "voxels", "gaussians"}));
  app.add_option("--moving-lod", o.moving_lod,
                 "Gaussian view while moving: chunks fine within FINE m, none beyond CUT m (0 = off; default 2,60)")
      ->expected(2)
      ->delimiter(',')
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--still-lod", o.still_lod, "Gaussian view at rest: FINE,CUT as --moving-lod (default 40,0)")
      ->expected(2)
      ->delimiter(',')
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--chunk-size", o.chunk_size, "Gaussian view: chunk size in metres (default 12.8)")
      ->check(CLI::Range(1.0, 1000.0));
  app.add_option("--scene", o.scene_path, "Scene (icube JSON, Waymo TFRecord, OpenDRIVE): ego track, cars, camera; "
                                          "without a world, its world is built with the procedural prior");
  app.add_option("--frames", o.frames, "Close after this many frames (0 = run until closed)");
  app.add_option("--size", o.width, "Window width (height follows 16:9 unless --height)");
  app.add_option("--height", o.height, "Window height");
  app.add_option("--scale", o.scale, "Resolution scale of the view (0.25..1)")->check(CLI::Range(0.25, 1.0));
  app.add_flag("--adaptive", o.adaptive, "Adaptive resolution while moving (towards --target-ms)");
  app.add_option("--target-ms", o.target_ms, "Frame-time target of the adaptive resolution (default 45: 20 fps with margin)");
  app.add_option("--resident-radius", o.resident_radius,
                 "Metres around the camera whose chunks are on the GPU, nearest first up to 80k bricks (0 = the "
                 "whole world; default: the whole world when it fits, else 150 m)");
  app.add_option("--mode", o.mode, "Render mode")->check(CLI::IsMember({"shaded", "semantic", "depth", "instance", "coords"}));
  app.add_option("--vfov", o.vfov, "Vertical field of view in degrees (0 = the target camera's)");
  app.add_option("--frames-per-pass", o.interp_frames, "Interpolated frames per saved pass")->check(CLI::Range(2, 100000));
  app.add_option("--script", o.script, "Scripted session: timed key events and commands (viewer/script.h); exits at its end");
  app.add_flag("--autopilot", o.autopilot, "Drive the scene's ego track; without --script: record it, save, screenshot, exit");
  app.add_option("--record-out", o.record_out, "Where 'save' writes the .npy (JSON per pass next to it)");
  app.add_option("--screenshot-out", o.screenshot_out, "Where 'screenshot' writes the PNG");
  app.add_option("--load", o.load, "Trajectory (.npy [N,4,4]/[P,N,4,4] or JSON) to replay");
  app.add_option("--max-seconds", o.max_seconds, "Scripted runs fail after this many simulated seconds");
  app.add_flag("--stats", o.stats,
               "Print frame-time percentiles at exit, the p50 of each part of a frame (host, presenter, device "
               "timestamps) and the residency slices");
  app.add_flag("!--no-vsync", o.vsync, "Present without waiting for vblank (mailbox/immediate) for measurements");
  app.add_option("--verify", o.verify, "No window: check a saved trajectory (shape, forward progress, camera "
                                      "height above the input world's ground) and exit 0 / 1");
  app.add_option("--expect-passes", o.expect_passes, "With --verify: the number of passes expected (0 = any)");
  app.add_option("--compare-semantic", o.compare,
                 "No window: compare the viewer's semantic PNG (frame-shot) with icube buffers' semantic_buffer PNG "
                 "of the same pose and exit 0 / 1")->expected(2);
  app.add_option("--compare-rgb", o.compare_rgb,
                 "No window: compare two RGB PNGs (the Gaussian view's gaussian-shot with `icube splat render`'s "
                 "frame of the same pose) and exit 0 / 1")
      ->expected(2);
  app.add_option("--max-level-diff", o.max_level_diff, "With --compare-rgb: channel levels a pixel may differ by")
      ->check(CLI::Range(0, 255));
  app.add_option("--max-mismatch", o.max_mismatch,
                 "With --compare-semantic / --compare-rgb: the fraction of pixels allowed to differ")
      ->check(CLI::Range(0.0, 1.0));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (app.count("--height") == 0) o.height = o.width * 9 / 16;
  return -1;
}

int run_verify(const Options& o) {
  try {
    const std::vector<Pass> passes = load_passes(o.verify);
    std::optional<world::VoxelGrid> grid;
    std::string world_path = o.input;
    if (!world_path.empty() && std::filesystem::is_directory(world_path)) world_path += "/world.icw";
    if (!world_path.empty()) grid = world::load_world(world_path);
    PassCheckOptions co;
    co.passes = o.expect_passes;
    co.frames = static_cast<size_t>(o.interp_frames);
    co.camera_height = scene::kWaymoFrontMount.z;
    const std::vector<std::string> bad = check_passes(passes, grid ? &*grid : nullptr, co);
    std::printf("icube-view: %s: %zu pass(es) x %zu poses%s\n", o.verify.c_str(), passes.size(),
                passes.empty() ? size_t{0} : passes[0].size(), grid ? ", heights checked on the world" : "");
    for (const std::string& b : bad) std::fprintf(stderr, "icube-view: verify: %s\n", b.c_str());
    std::printf("icube-view: verify %s\n", bad.empty() ? "ok" : "FAILED");
    return bad.empty() ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-view: error: %s\n", e.what());
    return 1;
  }
}

int run_compare_rgb(const Options& o) {
  try {
    const scene::Image8 a = scene::read_png(o.compare_rgb.at(0), 3), b = scene::read_png(o.compare_rgb.at(1), 3);
    if (a.width != b.width || a.height != b.height)
      throw std::invalid_argument(o.compare_rgb[0] + " is " + std::to_string(a.width) + "x" + std::to_string(a.height) +
                                  ", " + o.compare_rgb[1] + " is " + std::to_string(b.width) + "x" +
                                  std::to_string(b.height));
    const size_t n = size_t(a.width) * size_t(a.height);
    size_t bad = 0, first = n;
    int worst = 0;
    double se = 0.0;
    for (size_t i = 0; i < n; ++i) {
      int d = 0;
      for (size_t c = 0; c < 3; ++c) {
        const int e = int(a.pixels[3 * i + c]) - int(b.pixels[3 * i + c]);
        d = std::max(d, std::abs(e));
        se += double(e) * double(e);
      }
      worst = std::max(worst, d);
      if (d > o.max_level_diff) {
        if (first == n) first = i;
        ++bad;
      }
    }
    const double psnr = se > 0.0 ? 10.0 * std::log10(255.0 * 255.0 * 3.0 * double(n) / se) : 99.0;
    const double frac = n ? double(bad) / double(n) : 0.0;
    std::printf("icube-view: compare %s vs %s: %zu pixels, %zu differ by more than %d levels (%.4f%%, limit %.4f%%), "
                "largest difference %d, PSNR %.1f dB\n",
                o.compare_rgb[0].c_str(), o.compare_rgb[1].c_str(), n, bad, o.max_level_diff, 100.0 * frac,
                100.0 * o.max_mismatch, worst, psnr);
    if (first < n)
      std::printf("icube-view: first difference at (%zu, %zu)\n", first % size_t(a.width), first / size_t(a.width));
    const bool ok = frac <= o.max_mismatch;
    std::printf("icube-view: compare %s\n", ok ? "ok" : "FAILED");
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-view: error: %s\n", e.what());
    return 1;
  }
}

int run_compare(const Options& o) {
  try {
    const scene::Image8 a = scene::read_png(o.compare.at(0), 3), b = scene::read_png(o.compare.at(1), 3);
    if (a.width != b.width || a.height != b.height)
      throw std::invalid_argument(o.compare[0] + " is " + std::to_string(a.width) + "x" + std::to_string(a.height) + ", " +
                                  o.compare[1] + " is " + std::to_string(b.width) + "x" + std::to_string(b.height));
    const SemanticComparison c = compare_semantic(a.pixels, 3, b.pixels, 3);
    std::printf("icube-view: compare %s vs %s: %zu pixels, %zu equal, %zu instance-coloured on vehicles, %zu differ "
                "(%.4f%%, limit %.4f%%)\n",
                o.compare[0].c_str(), o.compare[1].c_str(), c.pixels, c.equal, c.instance, c.mismatched,
                100.0 * c.mismatch_fraction(), 100.0 * o.max_mismatch);
    if (c.mismatched > 0) {
      const size_t i = c.first_mismatch;
      const uint8_t* p = &a.pixels[3 * i];
      const uint8_t* q = &b.pixels[3 * i];
      std::printf("icube-view: first difference at (%zu, %zu): viewer %u,%u,%u buffer %u,%u,%u\n", i % size_t(a.width),
                  i / size_t(a.width), p[0], p[1], p[2], q[0], q[1], q[2]);
    }
    const bool ok = c.mismatch_fraction() <= o.max_mismatch;
    std::printf("icube-view: compare %s\n", ok ? "ok" : "FAILED");
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-view: error: %s\n", e.what());
    return 1;
  }
}

}  // namespace icube::viewer
