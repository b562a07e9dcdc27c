// `icube generate` (the main job): scene → Stage 1 voxel world → Stage 2
// guidance buffers and appearance frames → Stage 3 static Gaussians and sky,
// written as one package.
//
//   icube generate SCENE -o PACKAGE [--world WORLD.icw] [--prompt TEXT] [--seed N]
//                  [--frames A:B[:S]] [--camera ... | --camera-preset NAME | --trajectory F | --route M]
//                  [--key-every N] [--gaussians-per-cell 1|4] [--no-video]
//
// PACKAGE (see docs/generate.md): world.icw, buffers/<clip>/ (InfiniCube's
// Stage-2 layout) + buffers/contact_sheet.png, frames/ (appearance frames),
// gaussians/ (gaussians_static.ply, sky.png, scene.json, lift_report.json,
// eval.png), manifest.json (inputs with their SHA-256, options, seed, stages,
// SHA-256 of every file; the same inputs give the same bytes). Time and peak
// memory per stage are printed as a table at the end. The package is built in a hidden staging
// folder beside PACKAGE and renamed into place at the end, so an interrupted
// run leaves nothing that looks complete.
// Engines: engine/world (procedural prior), engine/render (buffers, frames),
// engine/lift.
#include "camera_path.h"
#include "cli_common.h"
#include "command_registry.h"
#include "progress.h"
#include "staging_dir.h"

#include "gpu/context.h"
#include "lift/lift_frames.h"
#include "lift/lift_output.h"
#include "render/appearance/frames_render.h"
#include "render/appearance/prompt.h"
#include "render/buffers/contact_sheet.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/guidance_sequence.h"
#include "render/buffers/overlay_world.h"
#include "render/buffers/stage2_writer.h"
#include "scene/atomic_file.h"
#include "scene/sha256.h"
#include "world/car_mesh.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace icube::tools {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

inline constexpr const char* kPackageFormat = "icube-package";
inline constexpr int kPackageVersion = 1;

struct GenerateArgs {
  CameraPathArgs path;
  std::string world, output, prompt = render::kDefaultAppearancePrompt;
  uint32_t seed = 0;
  size_t key_every = 2;
  int per_cell = 1;
  bool no_video = false;
};

double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;  // KiB on Linux
}

struct StageRecord {
  std::string name;
  double seconds = 0.0, peak_rss_mib = 0.0;
  std::string detail;
};

// Every regular file under `root`, sorted, as paths relative to it.
std::vector<std::string> package_files(const fs::path& root) {
  std::vector<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) out.push_back(fs::relative(e.path(), root).generic_string());
  std::sort(out.begin(), out.end());
  return out;
}

void cmd_generate(const GenerateArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    const auto t_start = Clock::now();
    if (a.path.scene.empty()) throw std::invalid_argument("give the SCENE");
    if (a.output.empty()) throw std::invalid_argument("give -o PACKAGE");
    refuse_overwriting_input(a.path.scene, a.output);
    if (!a.world.empty()) refuse_overwriting_input(a.world, a.output);
    CameraPath cp = resolve_camera_path(a.path, diag);
    if (cp.passes.size() != 1)
      throw std::invalid_argument("generate takes one camera pass; the trajectory file holds " +
                                  std::to_string(cp.passes.size()));
    const scene::Scene& sc = *cp.scene;
    const render::Trajectory& traj = cp.passes[0];
    const render::AppearancePrompt parsed = render::parse_prompt(a.prompt);
    const fs::path final_dir = fs::absolute(a.output);
    StagingDir staging(final_dir.parent_path(), final_dir.filename().string());
    std::vector<StageRecord> stages;
    auto stage_done = [&](const std::string& name, Clock::time_point t0, const std::string& detail) {
      stages.push_back({name, std::chrono::duration<double>(Clock::now() - t0).count(), peak_rss_mib(), detail});
      std::fprintf(stderr, "[%s] %.1f s: %s\n", name.c_str(), stages.back().seconds, detail.c_str());
    };

    // Stage 1: the voxel world.
    auto t0 = Clock::now();
    const std::string world_source = a.world.empty() ? "procedural" : a.world;
    const world::VoxelGrid world = [&] {
      if (!a.world.empty()) return world::load_world(a.world);
      const world::ProceduralPrior prior(sc);
      world::WorldBuildOptions wo;
      wo.seed = a.seed;
      ProgressBar bar("world", "chunks");
      wo.progress = [&](size_t done, size_t total) { bar.update(done, total); };
      world::WorldBuildResult r = world::build_world(sc, prior, wo);
      for (const std::string& note : r.plan.notes) diag.warn(a.path.scene, "plan", note);
      return std::move(r.world);
    }();
    world::save_world(world, (staging.path / "world.icw").string());
    stage_done("world", t0, std::to_string(world.voxel_count()) + " voxels in " + std::to_string(world.brick_count()) +
                                " bricks (" + world_source + ")");

    // Stage 2: the static scene on the GPU once; guidance buffers, then the appearance frames.
    t0 = Clock::now();
    const world::TriangleMesh mesh = world::builtin_car_mesh();
    const int t0_index = traj.time_index.empty() ? 0 : std::max(0, traj.time_index[0]);
    const world::VoxelGrid static_world = render::make_static_world(world, sc, t0_index, mesh);
    gpu::Context ctx(gpu::ContextOptions::from_env());
    render::OverlayWorld overlay(ctx, static_world);
    const std::string clip = "clip";
    {
      ProgressBar bar("buffers", "frames");
      render::SequenceOptions so;
      so.seed = a.seed;
      so.progress = [&](size_t done, size_t total) { bar.update(done, total); };
      const render::GuidanceSequence seq = render::render_sequence(ctx, overlay, &sc, mesh, cp.K, traj, so);
      const fs::path bdir = staging.path / "buffers" / clip;
      fs::create_directories(bdir);
      render::Stage2Options wo;
      wo.clip = clip;
      wo.videos = !a.no_video;
      const render::Stage2Result wr =
          render::write_stage2(seq, &sc, render::world_to_voxel_world(traj.c2w[0]), bdir.string(), wo);
      for (const std::string& n : wr.notes) diag.warn(a.output, "buffers", n);
      render::write_contact_sheet((staging.path / "buffers" / "contact_sheet.png").string(),
                                  render::contact_sheet(seq, clip + ": " + std::to_string(seq.frames.size()) + " frames"));
    }
    stage_done("buffers", t0, std::to_string(traj.size()) + " frames " + std::to_string(cp.K.width) + "x" +
                                  std::to_string(cp.K.height));
    t0 = Clock::now();
    {
      const fs::path fdir = staging.path / "frames";
      fs::create_directories(fdir);
      ProgressBar bar("frames", "frames");
      render::FramesRenderOptions fo;
      fo.seed = a.seed;
      fo.progress = [&](size_t done, size_t total) { bar.update(done, total); };
      render::render_frames(ctx, overlay, static_world, &sc, mesh, cp.K, traj, a.prompt, fo, fdir.string());
    }
    stage_done("frames", t0, parsed.summary());

    // Stage 3: the static Gaussians and the sky from the frames.
    t0 = Clock::now();
    const render::FramesMeta meta = render::read_frames_meta((staging.path / "frames").string());
    lift::LiftFramesOptions lo;
    lo.key_every = a.key_every;
    lo.lift.per_cell = a.per_cell;
    lo.scene = &sc;
    lo.car_mesh = &mesh;
    ProgressBar lift_bar("lift", "frames");
    lo.progress = [&](const char* stage, size_t done, size_t total) {
      if (std::string(stage) == "lift") lift_bar.update(done, total);
    };
    const lift::LiftFramesResult lr = lift::lift_frames(ctx, static_world, (staging.path / "frames").string(), meta, lo);
    lift::write_lift_outputs((staging.path / "gaussians").string(), meta, lr, lo);
    size_t object_gaussians = 0;
    for (const auto& obj : lr.objects) object_gaussians += obj.gaussians.size();
    char lift_detail[200];
    std::snprintf(lift_detail, sizeof lift_detail,
                  "%zu static Gaussians, %zu dynamic objects (%zu Gaussians), held-out PSNR %.2f dB over %zu frames",
                  lr.cloud.size(), lr.objects.size(), object_gaussians, lr.mean_psnr(), lr.eval.size());
    stage_done("lift", t0, lift_detail);

    // The manifest: inputs, options, stages, and every file's SHA-256 (itself excluded).
    nlohmann::ordered_json m;
    m["format"] = kPackageFormat;
    m["version"] = kPackageVersion;
    m["inputs"] = {{"scene", a.path.scene}, {"scene_sha256", scene::sha256_file(a.path.scene)},
                   {"world", a.world.empty() ? nlohmann::ordered_json("procedural") : nlohmann::ordered_json(a.world)}};
    if (!a.world.empty()) m["inputs"]["world_sha256"] = scene::sha256_file(a.world);
    m["options"] = {{"prompt", a.prompt},       {"seed", a.seed},         {"frames", a.path.frames},
                    {"camera", {cp.K.fx, cp.K.fy, cp.K.cx, cp.K.cy, cp.K.width, cp.K.height}},
                    {"key_every", a.key_every}, {"gaussians_per_cell", a.per_cell}, {"videos", !a.no_video}};
    m["frames"] = traj.size();
    nlohmann::ordered_json st = nlohmann::ordered_json::array();
    for (const StageRecord& s : stages)
      st.push_back({{"stage", s.name}, {"detail", s.detail}});
    m["stages"] = st;  // times and memory are printed, not stored: the same inputs give the same bytes
    nlohmann::ordered_json files = nlohmann::ordered_json::object();
    for (const std::string& f : package_files(staging.path)) files[f] = scene::sha256_file((staging.path / f).string());
    m["files"] = files;
    scene::write_file_atomic((staging.path / "manifest.json").string(), m.dump(1) + "\n");

    if (fs::exists(final_dir)) fs::remove_all(final_dir);
    fs::rename(staging.path, final_dir);
    staging.keep = true;
    const double total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
    std::printf("generate: %s -> %s\n%-10s %10s %14s  %s\n", a.path.scene.c_str(), final_dir.string().c_str(), "stage",
                "seconds", "peak RSS MiB", "result");
    for (const StageRecord& s : stages)
      std::printf("%-10s %10.1f %14.0f  %s\n", s.name.c_str(), s.seconds, s.peak_rss_mib, s.detail.c_str());
    std::printf("%-10s %10.1f\n", "total", total_s);
  });
}

void add_generate_command(CLI::App& app) {
  auto a = std::make_shared<GenerateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "generate", "The main job: scene -> voxel world -> guidance buffers and frames -> 3D Gaussians, as one package");
  cmd->add_option("scene_file", a->path.scene, "Scene (icube JSON, Waymo TFRecord, OpenDRIVE)")->type_name("SCENE");
  a->path.add_options(cmd);
  cmd->add_option("--world", a->world, "Use this voxel world (e.g. from `world build --generator diffusion`) for Stage 1")
      ->type_name("WORLD.icw");
  cmd->add_option("--prompt", a->prompt, "Text prompt of the appearance frames (time of day, weather, season)")
      ->type_name("TEXT")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "Seed of every stage (world detail, instance colours, appearance)")
      ->capture_default_str();
  cmd->add_option("--key-every", a->key_every, "Stage 3 lifts every N-th frame; the others are held out")
      ->capture_default_str()
      ->check(CLI::Range(size_t{1}, size_t{1000000}));
  cmd->add_option("--gaussians-per-cell", a->per_cell, "Gaussians per seen 0.1 m face cell (1, or 4: official density)")
      ->capture_default_str()
      ->check(CLI::IsMember({1, 4}));
  cmd->add_flag("--no-video", a->no_video, "No mp4s in the guidance buffers");
  cmd->add_option("-o,--output", a->output, "Package folder")->type_name("PACKAGE");
  cmd->footer(
      "Stage 1 with the procedural world prior (or --world), Stage 2 with the built-in appearance renderer, Stage 3 "
      "with the non-learned lifting of docs/stage3-lifting.md. The package is written atomically; see docs/generate.md.");
  cmd->callback([a] { cmd_generate(*a); });
}

const CommandRegistrar kRegistrar(add_generate_command, 5);

}  // namespace

}  // namespace icube::tools
