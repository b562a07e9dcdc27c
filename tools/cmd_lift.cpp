// `icube lift` (Stage 3): the static scene's Gaussians and sky lifted from an
// appearance-frames folder and the voxel world, with held-out figures.
//
//   icube lift WORLD FRAMES_DIR [--scene SCENE] [--key-every N] [--gaussians-per-cell 1|4]
//              [--face-gaussians] [--no-hidden] [--eval-frames N] -o OUT_DIR
//   icube lift WORLD FRAMES_DIR --gsm DIR | --gsm-model CONFIG --gsm-weights W [--scene SCENE]
//              [--key-every N] [--pixel-frames N] [--gsm-size WxH] [--gsm-radius M] [--gsm-backend gpu|cpu] -o OUT_DIR
//
// With --gsm the learned model (engine/lift/gsm_lift.h) replaces the
// non-learned lift and writes the same files; its configuration, its input
// size and its weights (every tensor against the configuration, finite) are
// checked before any work (tools/gsm_lift_options.h).
//
// OUT_DIR: gaussians_static.ply (3DGS layout, SH0), sky.png (equirect
// panorama), with --scene object_<id>.ply per dynamic vehicle (object frame),
// scene.json (icube-splat-scene with the objects' tracks: `icube splat render`
// and `icube lidar --gaussians` open it), lift_report.json (counts, timings,
// held-out PSNR per frame) and eval.png (held-out frames: reference above,
// Gaussians below). Built in a
// staging folder and renamed into place: an error leaves nothing half-written.
// Engine: engine/lift/.
#include "cli_common.h"
#include "gsm_lift_options.h"
#include "command_registry.h"
#include "progress.h"
#include "staging_dir.h"

#include "gpu/context.h"
#include "lift/gsm_lift.h"
#include "lift/lift_frames.h"
#include "lift/lift_output.h"
#include "render/buffers/frame_scene.h"
#include "scene/scene_load.h"
#include "world/car_mesh.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace icube::tools {

namespace {

namespace fs = std::filesystem;

struct LiftArgs {
  std::string world, frames, scene, output;
  size_t key_every = 2, eval_frames = 4, pixel_frames = 1;
  int per_cell = 1;
  float cell_sigma = lift::kCellSigma;
  double hidden_radius = 40.0;
  bool face_gaussians = false, no_hidden = false;
  GsmCliArgs gsm;
};

// The voxel world the lift reads and the scene: with --scene, the frames were rendered from the world with
// the scene's vehicles as car meshes, so its parked cars are voxelised in and the vehicles' cells removed
// (render::make_static_world at the folder's first time index).
struct LiftWorld {
  world::VoxelGrid world;
  std::optional<scene::Scene> scene;
};

LiftWorld load_lift_world(const LiftArgs& a, const render::FramesMeta& meta, const world::TriangleMesh& mesh,
                          scene::Diagnostics& diag) {
  LiftWorld lw{world::load_world(a.world), std::nullopt};
  if (a.scene.empty()) return lw;
  lw.scene = scene::load_scene(a.scene, scene::LoadOptions{}, &diag);
  if (scene::tracks_unclassified(*lw.scene)) scene::classify_tracks(*lw.scene);
  const int t0 = meta.source_time_indices.empty() ? 0 : std::max(0, meta.source_time_indices[0]);
  lw.world = render::make_static_world(lw.world, *lw.scene, t0, mesh);
  return lw;
}

// `icube lift --gsm`: the learned lift, into the same files.
void cmd_lift_gsm(const LiftArgs& a, const lift::GsmModelPaths& paths, scene::Diagnostics& diag) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  refuse_overwriting_input(a.world, a.output);
  refuse_overwriting_input(a.frames, a.output);
  for (const std::string& f : {paths.config, paths.weights}) refuse_overwriting_input(f, a.output);
  lift::GsmLiftOptions o;
  apply_gsm_options(a.gsm, a.key_every, o);
  o.pixel_frames = a.pixel_frames;
  o.max_eval_frames = a.eval_frames;
  // Before any work: the configuration, the sizes it would run at, the weights.
  const nn::GsmModelConfig config = lift::load_gsm_lift_config(paths);
  const render::FramesMeta meta = render::read_frames_meta(a.frames);
  gpu::Context ctx(gpu::ContextOptions::from_env());  // its storage-binding size bounds the key frames' size
  if (!o.cpu_reference) o.max_view_pixels = lift::gsm_max_view_pixels(ctx.info().max_storage_buffer_range);
  lift::gsm_lift_plan(meta.poses.size(), meta.width, meta.height, a.frames + "/frames_meta.json", config.config, o);
  const lift::GsmLiftModel model = lift::load_gsm_lift_model(paths);
  const world::TriangleMesh mesh = world::builtin_car_mesh();
  LiftWorld lw = load_lift_world(a, meta, mesh, diag);
  const world::VoxelGrid& world = lw.world;
  if (lw.scene) {
    o.scene = &*lw.scene;
    o.car_mesh = &mesh;
  }
  ProgressBar frames_bar("frames", "frames");
  ProgressBar gsm_bar("gsm", "stages");
  ProgressBar eval_bar("eval", "frames");
  o.progress = [&](const char* stage, size_t done, size_t total) {
    const std::string s(stage);
    (s == "frames" ? frames_bar : s == "gsm" ? gsm_bar : eval_bar).update(done, total);
  };
  const lift::GsmLiftResult r = lift::gsm_lift_frames(ctx, world, a.world, a.frames, meta, model, o);

  const fs::path final_dir = fs::absolute(a.output);
  StagingDir staging(final_dir.parent_path(), final_dir.filename().string());
  lift::write_gsm_lift_outputs(staging.path.string(), meta, r, o);
  staging.move_into_place(final_dir);
  const double total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
  const lift::GsmLiftStats& g = r.gsm;
  for (const auto& [label, ms] : g.stages_ms) std::fprintf(stderr, "lift: gsm %-60s %9.1f ms\n", label.c_str(), ms);
  std::printf("lift (gsm): %zu key frames of %zu at %ux%u, %zu input voxels (%zu first hits) -> %zu Gaussians (%zu voxel, "
              "%zu pixel), %zu dynamic objects (%zu Gaussians, %zu key frames); held-out PSNR %.2f dB over %zu frames; "
              "%.2f s [inputs %.2f, forward %.2f, dynamic %.2f, eval %.2f] -> %s\n",
              r.lift.key_frames.size(), meta.poses.size(), g.width, g.height, g.input_voxels, g.front_voxels,
              r.lift.cloud.size(), g.voxel_gaussians, g.pixel_gaussians, r.lift.objects.size(), r.lift.object_gaussians(),
              g.dynamic_views, r.lift.mean_psnr(), r.lift.eval.size(), total_s, g.inputs_s, g.forward_s, g.dynamic_s,
              r.lift.eval_s, final_dir.string().c_str());
}

void cmd_lift(const LiftArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    if (const std::optional<lift::GsmModelPaths> gsm = gsm_paths_of(a.gsm)) return cmd_lift_gsm(a, *gsm, diag);
    using Clock = std::chrono::steady_clock;
    const auto t_start = Clock::now();
    refuse_overwriting_input(a.world, a.output);
    refuse_overwriting_input(a.frames, a.output);
    const render::FramesMeta meta = render::read_frames_meta(a.frames);
    const world::TriangleMesh mesh = world::builtin_car_mesh();
    const LiftWorld lw = load_lift_world(a, meta, mesh, diag);
    const world::VoxelGrid& world = lw.world;
    const std::optional<scene::Scene>& sc = lw.scene;
    gpu::Context ctx(gpu::ContextOptions::from_env());
    lift::LiftFramesOptions o;
    o.key_every = a.key_every;
    o.max_eval_frames = a.eval_frames;
    o.lift.per_cell = a.per_cell;
    o.lift.face_gaussians = a.face_gaussians;
    o.lift.hidden = !a.no_hidden;
    o.lift.cell_sigma = a.cell_sigma;
    o.lift.hidden_radius = a.hidden_radius;
    o.pixel_frames = a.pixel_frames;
    if (sc) o.scene = &*sc, o.car_mesh = &mesh;
    ProgressBar lift_bar("lift", "frames");
    ProgressBar eval_bar("eval", "frames");
    o.progress = [&](const char* stage, size_t done, size_t total) {
      (std::string(stage) == "lift" ? lift_bar : eval_bar).update(done, total);
    };
    const lift::LiftFramesResult r = lift::lift_frames(ctx, world, a.frames, meta, o);

    const fs::path final_dir = fs::absolute(a.output);
    StagingDir staging(final_dir.parent_path(), final_dir.filename().string());
    lift::write_lift_outputs(staging.path.string(), meta, r, o);
    staging.move_into_place(final_dir);
    const double total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
    std::printf("lift: %zu key frames of %zu, %zu samples -> %zu Gaussians (%zu surface, %zu hidden), %zu dynamic "
                "objects (%zu Gaussians from %zu samples), sky from %zu pixels, %zu mid-ground pixels (%zu on the road "
                "plane, %zu at the world's bounds); held-out PSNR %.2f dB over %zu frames; %.2f s [cast %.2f, "
                "accumulate %.2f, emit %.2f, eval %.2f] -> %s\n",
                r.key_frames.size(), meta.poses.size(), r.samples, r.cloud.size(), r.stats.surface_gaussians,
                r.stats.hidden_gaussians, r.objects.size(), r.object_gaussians(), r.dynamic_samples, r.sky_samples,
                r.pixel.pixels, r.pixel.ground, r.pixel.backdrop, r.mean_psnr(), r.eval.size(), total_s, r.cast_s,
                r.accumulate_s, r.emit_s, r.eval_s, final_dir.string().c_str());
  });
}

void add_lift_command(CLI::App& app) {
  auto a = std::make_shared<LiftArgs>();
  CLI::App* cmd = app.add_subcommand(
      "lift", "Stage 3: lift the static scene's 3D Gaussians and sky from appearance frames and the voxel world");
  cmd->add_option("world", a->world, "World file (.icw) the frames were rendered from")->required()->type_name("WORLD");
  cmd->add_option("frames", a->frames, "Appearance-frames folder (icube frames render / import)")
      ->required()
      ->type_name("FRAMES_DIR");
  cmd->add_option("--scene", a->scene,
                  "The scene the frames were rendered with: its vehicles as car meshes, its moving ones lifted into "
                  "their object frames")
      ->type_name("SCENE");
  a->gsm.key_every =
      cmd->add_option("--key-every", a->key_every,
                      "Lift from every N-th frame; the others are held out for the figures (with --gsm default 6)")
          ->capture_default_str()
          ->check(CLI::Range(size_t{1}, size_t{1000000}));
  cmd->add_option("--gaussians-per-cell", a->per_cell,
                  "Gaussians per seen 0.1 m face cell: 1, or 4 (the official density, 4 per sub-voxel)")
      ->capture_default_str()
      ->check(CLI::IsMember({1, 4}));
  cmd->add_flag("--face-gaussians", a->face_gaussians, "One Gaussian per seen voxel face (coarse, 4x fewer)");
  cmd->add_option("--cell-sigma", a->cell_sigma, "Surfel σ along the face in 0.1 m cell sizes (halved at 4 per cell)")
      ->capture_default_str()
      ->check(CLI::Range(0.05f, 4.0f));
  cmd->add_flag("--no-hidden", a->no_hidden, "No Gaussians for surface voxels no frame sees");
  cmd->add_option("--hidden-radius", a->hidden_radius,
                  "Hidden surface voxels get a Gaussian only within this many metres of a frame's camera")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e7));
  cmd->add_option("--pixel-frames", a->pixel_frames,
                  "Pixel branch: Gaussians for the mid-ground pixels (not sky, no voxel hit) of the last N key frames "
                  "(0 = off; needs sky masks segmented from the frames, see `icube frames import --sky-masks`)")
      ->capture_default_str();
  cmd->add_option("--eval-frames", a->eval_frames, "Held-out frames rendered for the PSNR figures and eval.png")
      ->capture_default_str();
  add_gsm_options(cmd, a->gsm);
  cmd->add_option("-o,--output", a->output, "Output folder")->required()->type_name("OUT_DIR");
  cmd->footer(
      "Non-learned voxel branch: each key frame's pixels (not sky, not dynamic objects) colour the 0.1 m cells of "
      "the voxel faces they hit; every seen cell becomes flat Gaussians on that face, hidden surface voxels one "
      "Gaussian in their class's colour. Mid-ground pixels of the last key frame (sky masks segmented from the "
      "frames say not sky, no voxel hit) become two Gaussians each on the road plane or at the world's bounds. The "
      "sky is an equirectangular panorama of the sky pixels. With --gsm the learned model (InfiniCube's GSM) lifts the "
      "key frames instead: voxel and pixel Gaussians, the moving cars from its pixel branch, the sky from its sky "
      "token (docs/stage3-lifting.md, \"The learned lift (GSM)\").");
  cmd->callback([a] { cmd_lift(*a); });
}

const CommandRegistrar kLiftRegistrar(add_lift_command, 48);

}  // namespace

}  // namespace icube::tools
