#include "generate_job.h"

#include "cli_common.h"
#include "package_staging.h"
#include "progress.h"

#include "gpu/context.h"
#include "lift/flythrough.h"
#include "lift/lift_frames.h"
#include "lift/lift_output.h"
#include "render/appearance/frames_import.h"
#include "render/appearance/frames_render.h"
#include "render/buffers/contact_sheet.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/guidance_sequence.h"
#include "render/buffers/overlay_world.h"
#include "render/buffers/stage2_writer.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/package_check.h"
#include "scene/scene_json.h"
#include "scene/sha256.h"
#include "world/car_mesh.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>

namespace icube::tools {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;  // KiB on Linux
}

// Every regular file under `root` but the stages file, sorted, as paths relative to it.
std::vector<std::string> package_files(const fs::path& root) {
  std::vector<std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file() && e.path().filename() != kStagesFile)
      out.push_back(fs::relative(e.path(), root).generic_string());
  std::sort(out.begin(), out.end());
  return out;
}

// SHA-256 of a file, or of a folder's files (sorted by name: "name sha256\n" each) for --frames-from.
std::string sha256_of_path(const std::string& path) {
  if (!fs::is_directory(path)) return scene::sha256_file(path);
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(path))
    if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::string list;
  for (const fs::path& f : files) list += f.filename().string() + " " + scene::sha256_file(f.string()) + "\n";
  return scene::sha256_hex(list);
}

// Test hook: ICUBE_GENERATE_KILL_AFTER=STAGE kills the process (SIGKILL, no
// clean-up) right after STAGE is recorded, as a node failure would.
void kill_hook(const std::string& stage) {
  const char* k = std::getenv("ICUBE_GENERATE_KILL_AFTER");
  if (k && stage == k) raise(SIGKILL);
}

}  // namespace

GenerateResult generate_package(const GenerateArgs& a, scene::Diagnostics& diag) {
  const auto t_start = Clock::now();
  if (a.path.scene.empty()) throw std::invalid_argument("give the SCENE");
  if (a.output.empty()) throw std::invalid_argument("give -o PACKAGE");
  refuse_overwriting_input(a.path.scene, a.output);
  if (!a.world.empty()) refuse_overwriting_input(a.world, a.output);
  if (!a.frames_from.empty()) refuse_overwriting_input(a.frames_from, a.output);
  if (!a.sky_masks.empty() && a.frames_from.empty())
    throw std::invalid_argument("--sky-masks goes with --frames-from (masks segmented from those frames)");
  if (!a.sky_masks.empty()) refuse_overwriting_input(a.sky_masks, a.output);
  CameraPath cp = resolve_camera_path(a.path, diag);
  if (cp.passes.size() != 1)
    throw std::invalid_argument("generate takes one camera pass; the trajectory file holds " +
                                std::to_string(cp.passes.size()));
  const scene::Scene& sc = *cp.scene;
  const render::Trajectory& traj = cp.passes[0];
  const render::AppearancePrompt parsed = render::parse_prompt(a.prompt);
  if (!a.frames_from.empty() && fs::is_directory(a.frames_from)) {  // before any stage: one frame per camera pose
    const size_t n = render::png_files(a.frames_from).size();
    if (n != traj.size())
      throw scene::InputError(a.frames_from, "", std::to_string(n) + " .png frames, but the camera path has " +
                                                     std::to_string(traj.size()) + " frames; frames are matched by index");
  } else if (!a.frames_from.empty() && !fs::is_regular_file(a.frames_from)) {
    throw scene::InputError(a.frames_from, "", "neither a folder of PNG frames nor a video file");
  }
  if (!a.sky_masks.empty()) {  // before any stage too: one mask per camera pose (sizes: the import)
    const size_t n = render::png_files(a.sky_masks).size();
    if (n != traj.size())
      throw scene::InputError(a.sky_masks, "", std::to_string(n) + " sky masks, but the camera path has " +
                                                   std::to_string(traj.size()) + " frames; masks are matched by index");
  }

  // What the package is made of; its SHA-256 decides whether a staging folder may be resumed.
  nlohmann::ordered_json inputs = {{"scene", a.path.scene}, {"scene_sha256", scene::sha256_file(a.path.scene)}};
  inputs["world"] = a.world.empty() ? nlohmann::ordered_json("procedural") : nlohmann::ordered_json(a.world);
  if (!a.world.empty()) inputs["world_sha256"] = scene::sha256_file(a.world);
  if (!a.path.record.empty()) inputs["record"] = a.path.record;
  if (!a.frames_from.empty()) {
    inputs["frames_from"] = a.frames_from;
    inputs["frames_from_sha256"] = sha256_of_path(a.frames_from);
  }
  if (!a.sky_masks.empty()) {
    inputs["sky_masks"] = a.sky_masks;
    inputs["sky_masks_sha256"] = sha256_of_path(a.sky_masks);
    inputs["sky_label"] = a.sky_label;
  }
  if (!a.path.trajectory.empty()) {
    inputs["trajectory"] = a.path.trajectory;
    inputs["trajectory_sha256"] = scene::sha256_file(a.path.trajectory);
  }
  const nlohmann::ordered_json options = {
      {"prompt", a.prompt},       {"seed", a.seed},
      {"frames", a.path.frames},  {"camera", {cp.K.fx, cp.K.fy, cp.K.cx, cp.K.cy, cp.K.width, cp.K.height}},
      {"route_m", a.path.route_m}, {"key_every", a.key_every},
      {"gaussians_per_cell", a.per_cell}, {"pixel_frames", a.pixel_frames}, {"videos", !a.no_video}, {"video_preset", a.video_preset},
      {"preview", !a.no_preview}};
  const std::string fingerprint = scene::sha256_hex(inputs.dump() + "\n" + options.dump());

  GenerateResult result;
  result.package = fs::absolute(a.output);
  if (a.resume && fs::exists(result.package)) {
    const scene::PackageCheck done = scene::check_package(result.package.string());
    if (done.complete && done.fingerprint == fingerprint) {
      result.skipped = true;
      result.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
      return result;
    }
    std::fprintf(stderr, "icube: note: %s: %s; generating it again\n", result.package.c_str(),
                 done.complete ? "made with other inputs or options" : done.problem.c_str());
  }
  PackageStaging staging(result.package, fingerprint, a.resume);
  result.resumed_stages = staging.resumed_stages();
  if (result.resumed_stages)
    std::fprintf(stderr, "generate: resuming %s after stage '%s'\n", staging.path().c_str(),
                 generate_stage_names()[result.resumed_stages - 1].c_str());
  // Runs `body` (returning the stage's one-line detail) unless an earlier run finished the stage.
  auto stage = [&](const std::string& name, auto&& body) {
    if (const std::string* detail = staging.finished(name)) {
      result.stages.push_back({name, *detail, 0.0, peak_rss_mib(), true});
      return;
    }
    const auto t0 = Clock::now();
    const std::string detail = body();
    result.stages.push_back(
        {name, detail, std::chrono::duration<double>(Clock::now() - t0).count(), peak_rss_mib(), false});
    std::fprintf(stderr, "[%s] %.1f s: %s\n", name.c_str(), result.stages.back().seconds, detail.c_str());
    staging.finish(name, detail);
    kill_hook(name);
  };
  const fs::path root = staging.path();

  // Stage 1: the voxel world (read back from the staging folder when resumed).
  stage("world", [&] {
    const world::VoxelGrid w = [&] {
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
    world::save_world(w, (root / "world.icw").string());
    // The scene as read (map, tracks, ego, cameras) in the icube JSON: icube-view PACKAGE drives its ego track
    // and shows its cars in the voxel views; icube buffers / lidar take it as --scene.
    scene::write_scene_json(sc, (root / "scene.json").string());
    return std::to_string(w.voxel_count()) + " voxels in " + std::to_string(w.brick_count()) + " bricks (" +
           (a.world.empty() ? std::string("procedural") : a.world) + ")";
  });
  const world::VoxelGrid world = world::load_world((root / "world.icw").string());

  // Stage 2: the static scene on the GPU once; guidance buffers, then the appearance frames.
  const world::TriangleMesh mesh = world::builtin_car_mesh();
  const int t0_index = traj.time_index.empty() ? 0 : std::max(0, traj.time_index[0]);
  const world::VoxelGrid static_world = render::make_static_world(world, sc, t0_index, mesh);
  gpu::Context ctx(gpu::ContextOptions::from_env());
  std::optional<render::OverlayWorld> overlay;
  auto shared_overlay = [&]() -> render::OverlayWorld& {
    if (!overlay) overlay.emplace(ctx, static_world);
    return *overlay;
  };
  stage("buffers", [&] {
    const std::string clip = "clip";
    fs::remove_all(root / "buffers");  // what a killed run left half-written
    ProgressBar bar("buffers", "frames");
    render::SequenceOptions so;
    so.seed = a.seed;
    so.progress = [&](size_t done, size_t total) { bar.update(done, total); };
    const render::GuidanceSequence seq = render::render_sequence(ctx, shared_overlay(), &sc, mesh, cp.K, traj, so);
    const fs::path bdir = root / "buffers" / clip;
    fs::create_directories(bdir);
    render::Stage2Options wo;
    wo.clip = clip;
    wo.videos = !a.no_video;
    wo.video.preset = a.video_preset;
    const render::Stage2Result wr =
        render::write_stage2(seq, &sc, render::world_to_voxel_world(traj.c2w[0]), bdir.string(), wo);
    for (const std::string& n : wr.notes) diag.warn(a.output, "buffers", n);
    render::write_contact_sheet((root / "buffers" / "contact_sheet.png").string(),
                                render::contact_sheet(seq, clip + ": " + std::to_string(seq.frames.size()) + " frames"));
    return std::to_string(traj.size()) + " frames " + std::to_string(cp.K.width) + "x" + std::to_string(cp.K.height);
  });
  // The camera path in our world frame, pose i = package frame i, with the frames' scene times when they
  // have them (the frames of gaussians/scene.json then: icube splat render --trajectory places the cars).
  auto write_trajectory = [&] {
    bool timed = !traj.time_index.empty();
    for (int t : traj.time_index) timed = timed && t >= 0;
    scene::write_file_atomic((root / "trajectory.json").string(),
                             render::trajectory_json(traj.c2w, cp.K, timed ? &traj.time_index : nullptr));
  };
  stage("frames", [&] {
    const fs::path fdir = root / "frames";
    fs::remove_all(fdir);
    fs::remove(root / "trajectory.json");
    fs::create_directories(fdir);
    if (!a.frames_from.empty()) {
      render::FramesImportOptions io;
      io.prompt = a.prompt;
      io.sky_masks = a.sky_masks;
      io.sky_label = a.sky_label;
      const render::FramesImportReport rep =
          render::import_frames(a.frames_from, (root / "buffers" / "clip").string(), fdir.string(), io);
      for (const std::string& n : rep.notes) diag.warn(a.frames_from, "frames", n);
      write_trajectory();
      return "imported " + std::to_string(rep.frames) + " frames from " + a.frames_from +
             (rep.rescaled ? " (rescaled)" : "");
    }
    ProgressBar bar("frames", "frames");
    render::FramesRenderOptions fo;
    fo.seed = a.seed;
    fo.progress = [&](size_t done, size_t total) { bar.update(done, total); };
    render::render_frames(ctx, shared_overlay(), static_world, &sc, mesh, cp.K, traj, a.prompt, fo, fdir.string());
    write_trajectory();
    return parsed.summary();
  });
  overlay.reset();  // the lift casts against its own copies of the world

  // Stage 3: the static Gaussians, the moving cars and the sky from the frames.
  stage("lift", [&] {
    fs::remove_all(root / "gaussians");
    const render::FramesMeta meta = render::read_frames_meta((root / "frames").string());
    lift::LiftFramesOptions lo;
    lo.key_every = a.key_every;
    lo.lift.per_cell = a.per_cell;
    lo.pixel_frames = a.pixel_frames;
    lo.scene = &sc;
    lo.car_mesh = &mesh;
    ProgressBar lift_bar("lift", "frames");
    lo.progress = [&](const char* what, size_t done, size_t total) {
      if (std::string(what) == "lift") lift_bar.update(done, total);
    };
    const lift::LiftFramesResult lr = lift::lift_frames(ctx, static_world, (root / "frames").string(), meta, lo);
    lift::write_lift_outputs((root / "gaussians").string(), meta, lr, lo);
    size_t object_gaussians = 0;
    for (const auto& obj : lr.objects) object_gaussians += obj.gaussians.size();
    char detail[256];
    std::snprintf(detail, sizeof detail,
                  "%zu static Gaussians (%zu of %zu mid-ground pixels), %zu dynamic objects (%zu Gaussians), "
                  "held-out PSNR %.2f dB over %zu frames",
                  lr.cloud.size(), lr.pixel.gaussians, lr.pixel.pixels, lr.objects.size(), object_gaussians,
                  lr.mean_psnr(), lr.eval.size());
    return std::string(detail);
  });

  // The preview: the Gaussians along the trajectory (mp4 with videos) and a sheet against the frames.
  stage("preview", [&] {
    fs::remove_all(root / "preview");
    if (a.no_preview) return std::string("skipped (--no-preview)");
    const render::FramesMeta meta = render::read_frames_meta((root / "frames").string());
    const splat::SplatScene gs = splat::read_splat_scene((root / "gaussians" / "scene.json").string());
    const splat::SkyImage sky = splat::read_sky_png((root / "gaussians" / "sky.png").string());
    lift::FlythroughOptions fo;
    fo.video = !a.no_video;
    fo.mp4.preset = "medium";  // a fly-through for people, not an input of InfiniCube's models: 3-4x faster than veryslow
    ProgressBar bar("preview", "frames");
    fo.progress = [&](size_t done, size_t total) { bar.update(done, total); };
    const lift::FlythroughResult fr = lift::write_flythrough(ctx, gs, sky, meta, (root / "frames").string(),
                                                             (root / "preview").string(), fo);
    char detail[160];
    std::snprintf(detail, sizeof detail, "%zu frames of the Gaussians (%.0f drawn per frame)%s", fr.frames,
                  fr.mean_gaussians, fo.video ? ", flythrough.mp4" : "");
    return std::string(detail);
  });

  // The manifest: inputs, options, stages, and every file's SHA-256 (itself excluded).
  nlohmann::ordered_json m;
  m["format"] = scene::kPackageFormat;
  m["version"] = scene::kPackageVersion;
  m["fingerprint"] = fingerprint;
  m["inputs"] = inputs;
  m["options"] = options;
  m["frames"] = traj.size();
  nlohmann::ordered_json st = nlohmann::ordered_json::array();
  for (const GenerateStage& s : result.stages) st.push_back({{"stage", s.name}, {"detail", s.detail}});
  m["stages"] = st;  // times and memory are printed, not stored: the same inputs give the same bytes
  nlohmann::ordered_json files = nlohmann::ordered_json::object();
  for (const std::string& f : package_files(root)) files[f] = scene::sha256_file((root / f).string());
  m["files"] = files;
  scene::write_file_atomic((root / scene::kPackageManifest).string(), m.dump(1) + "\n");
  staging.commit();
  result.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
  return result;
}

void print_generate_summary(const GenerateResult& r, const std::string& scene) {
  std::printf("generate: %s -> %s\n%-10s %10s %14s  %s\n", scene.c_str(), r.package.string().c_str(), "stage",
              "seconds", "peak RSS MiB", "result");
  for (const GenerateStage& s : r.stages) {
    if (s.resumed)
      std::printf("%-10s %10s %14s  %s\n", s.name.c_str(), "resumed", "-", s.detail.c_str());
    else
      std::printf("%-10s %10.1f %14.0f  %s\n", s.name.c_str(), s.seconds, s.peak_rss_mib, s.detail.c_str());
  }
  std::printf("%-10s %10.1f\n", "total", r.seconds);
}

}  // namespace icube::tools
