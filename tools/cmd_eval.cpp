// `icube eval PACKAGE`: novel-view quality of a package's Gaussians at frames
// not used for lifting (PSNR, SSIM; T+o from each key frame T and a spread of
// held-out frames), map alignment of its guidance semantic buffers with the
// scene's road edges and lane lines, and LiDAR agreement between its voxel
// world and its Gaussians. A table, DIR/eval.json and DIR/eval.png (default
// DIR: PACKAGE-eval beside the package, which is left as it is).
//
//   icube eval PACKAGE [--scene SCENE] [--record SEL] [-o DIR] [--offsets 5,10] [--held-out N]
//              [--lidar-frames N] [--lidar-preset NAME] [--map-depth M] [--tolerance PX]
//
// Engine: engine/lift/package_eval.h; docs/evaluation.md.
#include "cli_common.h"
#include "command_registry.h"
#include "progress.h"
#include "staging_dir.h"

#include "gpu/context.h"
#include "lift/package_eval.h"
#include "scene/atomic_file.h"
#include "scene/package_check.h"
#include "scene/scene_load.h"
#include "scene/sha256.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace icube::tools {
namespace {

namespace fs = std::filesystem;

struct EvalArgs {
  std::string package, scene, record, output, lidar_preset = "waymo-top";
  std::vector<int> offsets = {5, 10};
  size_t held_out = 8, lidar_frames = 3;
  double map_depth = 40.0, tolerance = 2.0, paint_tolerance = 0.5;
};

// The scene: --scene, else the manifest's path (as given to generate, then beside the package).
std::string resolve_scene(const EvalArgs& a, const nlohmann::json& inputs, std::string* record) {
  const fs::path manifest = fs::path(a.package) / scene::kPackageManifest;
  std::string path = a.scene;
  if (path.empty()) {
    const std::string given = inputs.value("scene", std::string());
    for (const fs::path& p : {fs::path(given), fs::path(a.package).parent_path() / fs::path(given).filename()})
      if (!given.empty() && fs::is_regular_file(p)) {
        path = p.string();
        break;
      }
    if (path.empty())
      throw scene::InputError(manifest.string(), "/inputs/scene",
                              "'" + given + "' not found; give the scene with --scene");
  }
  const std::string want = inputs.value("scene_sha256", std::string());
  if (!want.empty() && scene::sha256_file(path) != want)
    throw scene::InputError(path, "", "not the scene the package was generated from (SHA-256 differs from " +
                                          manifest.string() + "'s inputs.scene_sha256)");
  *record = a.record.empty() ? inputs.value("record", std::string()) : a.record;
  return path;
}

void cmd_eval(const EvalArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    const scene::PackageCheck check = scene::check_package(a.package, false);
    if (!check.complete) throw std::runtime_error(check.problem);
    const nlohmann::json manifest =
        nlohmann::json::parse(scene::read_file((fs::path(a.package) / scene::kPackageManifest).string()));
    std::string record;
    const std::string scene_path = resolve_scene(a, manifest.value("inputs", nlohmann::json::object()), &record);
    scene::LoadOptions lo;
    lo.waymo_selector = record;
    scene::Scene sc = scene::load_scene(scene_path, lo, &diag);
    if (scene::tracks_unclassified(sc)) scene::classify_tracks(sc);

    lift::PackageEvalOptions o;
    o.offsets = a.offsets;
    o.max_heldout = a.held_out;
    o.lidar_frames = a.lidar_frames;
    o.lidar = render::lidar_preset(a.lidar_preset);
    o.max_map_depth = a.map_depth;
    o.map_tolerance_px = a.tolerance;
    o.paint_tolerance_m = a.paint_tolerance;
    std::map<std::string, std::unique_ptr<ProgressBar>> bars;
    o.progress = [&](const char* stage, size_t done, size_t total) {
      auto& b = bars[stage];
      if (!b) b = std::make_unique<ProgressBar>(stage, "frames");
      b->update(done, total);
    };
    fs::path out = a.output.empty() ? fs::path(fs::absolute(a.package).lexically_normal().string() + "-eval")
                                    : fs::absolute(a.output);
    refuse_overwriting_input(a.package, out.string());
    gpu::Context ctx(gpu::ContextOptions::from_env());
    const lift::PackageEval e = lift::evaluate_package(ctx, a.package, sc, o);
    StagingDir staging(out.parent_path(), out.filename().string());
    lift::write_package_eval(staging.path.string(), e, o);
    if (fs::exists(out)) fs::remove_all(out);
    fs::rename(staging.path, out);
    staging.keep = true;

    std::printf("eval: %s (%zu frames, %zu key frames) -> %s\n", a.package.c_str(), e.frames, e.key_frames.size(),
                out.c_str());
    std::printf("\nnovel views (static pixels; cars where the frames show them)\n%-10s %7s %8s %10s %8s %12s\n", "frames",
                "count", "skipped", "PSNR dB", "SSIM", "cars PSNR dB");
    for (const lift::NovelViewRow& r : e.novel)
      std::printf("%-10s %7zu %8zu %10.2f %8.4f %12.2f\n", r.label.c_str(), r.frames, r.skipped_key_frames, r.psnr,
                  r.ssim, r.psnr_dynamic);
    std::printf("\nmap alignment (%zu frames, depth <= %.0f m; guidance-buffer paint = curbs and lane markers)\n"
                "%-28s %9s %9s %9s %14s\n",
                e.map.frames, o.max_map_depth, "", "samples", "median", "p90", "within");
    auto drow = [&](const char* name, const lift::DistanceStats& s, const char* unit, double tol) {
      std::printf("%-28s %9zu %6.2f %-2s %6.2f %-2s %6.1f%% <= %g %s\n", name, s.samples, s.median, unit, s.p90, unit,
                  100.0 * s.within, tol, unit);
    };
    drow("road edges -> paint (image)", e.map.road_edges, "px", o.map_tolerance_px);
    drow("lane lines -> paint (image)", e.map.lane_lines, "px", o.map_tolerance_px);
    drow("paint -> map (ground)", e.map.marking_to_map, "m", o.paint_tolerance_m);
    std::printf("(map heights moved %+.2f m onto the world's ground, the median over %zu samples; spread p90 %.2f m)\n",
                e.map.ground_offset_median_signed, e.map.ground_offset.samples, e.map.ground_offset.p90);
    std::printf("\nLiDAR agreement (%s, %zu sweeps; Gaussians vs voxels)\n", a.lidar_preset.c_str(), e.lidar.frames);
    if (!e.lidar.note.empty()) std::printf("  none: %s\n", e.lidar.note.c_str());
    else {
      std::printf("%-16s %10s %10s %10s %10s %9s %9s %9s %10s\n", "rays", "count", "both", "voxel only", "GS only",
                  "p50 m", "p90 m", "p99 m", "mean m");
      auto lrow = [&](const char* name, const lift::LidarStats& s) {
        std::printf("%-16s %10llu %10llu %10llu %10llu %9.3f %9.3f %9.3f %10.3f\n", name,
                    static_cast<unsigned long long>(s.rays), static_cast<unsigned long long>(s.both),
                    static_cast<unsigned long long>(s.voxel_only), static_cast<unsigned long long>(s.gaussian_only),
                    s.p50, s.p90, s.p99, s.mean_signed);
      };
      lrow("all", e.lidar.all);
      lrow("in camera view", e.lidar.in_view);
    }
    std::printf("\n[novel views %.1f s, map %.1f s, LiDAR %.1f s]\n", e.seconds_novel, e.seconds_map, e.seconds_lidar);
  });
}

void add_eval_command(CLI::App& app) {
  auto a = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand(
      "eval", "Evaluate a package: novel views (PSNR, SSIM), map alignment, LiDAR agreement; table, eval.json, eval.png");
  cmd->add_option("package", a->package, "Package folder written by `icube generate`")->required()->type_name("PACKAGE");
  cmd->add_option("--scene", a->scene, "The scene it was generated from (default: the manifest's inputs.scene)")
      ->type_name("SCENE");
  cmd->add_option("--record", a->record, "Waymo record selector, as given to generate")->type_name("SEL");
  cmd->add_option("-o,--output", a->output, "Output folder (default PACKAGE-eval beside the package)")->type_name("DIR");
  cmd->add_option("--offsets", a->offsets, "Frames T+o after each key frame T to evaluate")
      ->delimiter(',')
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--held-out", a->held_out, "Held-out frames (evenly spread) of the held-out row; 0: none")
      ->capture_default_str();
  cmd->add_option("--lidar-frames", a->lidar_frames, "LiDAR sweeps compared (evenly spread); 0: none")
      ->capture_default_str();
  cmd->add_option("--lidar-preset", a->lidar_preset, "LiDAR model (render/lidar/lidar_model.h presets)")
      ->capture_default_str();
  cmd->add_option("--map-depth", a->map_depth, "Map samples and paint pixels up to this z-depth (m)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1000.0));
  cmd->add_option("--tolerance", a->tolerance, "Map -> paint tolerance in the image (px)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--paint-tolerance", a->paint_tolerance, "Paint -> map tolerance on the ground (m)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
  cmd->footer("See docs/evaluation.md for what each figure measures.");
  cmd->callback([a] { cmd_eval(*a); });
}

const CommandRegistrar kEvalRegistrar(add_eval_command, 7);

}  // namespace
}  // namespace icube::tools
