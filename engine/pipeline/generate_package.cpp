// The main job, stage by stage; see generate_package.h.
#include "pipeline/generate_package.h"

#include "pipeline/package_staging.h"

#include "gpu/context.h"
#include "lift/flythrough.h"
#include "lift/gsm_lift.h"
#include "lift/lift_frames.h"
#include "lift/lift_output.h"
#include "nn/gsm/gsm_preset.h"
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
#include "scene/package_layout.h"
#include "scene/scene_json.h"
#include "scene/sha256.h"
#include "world/car_mesh.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>

namespace icube::pipeline {

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

// One run: the checked inputs, the staging folder and the stages, each a method returning its one-line detail.
class GenerateJob {
 public:
  GenerateJob(const GenerateArgs& args, scene::Diagnostics& diagnostics) : a(args), diag(diagnostics) {}

  GenerateResult run();

 private:
  void check_inputs();
  void fingerprint_inputs();
  // Runs `body` (returning the stage's one-line detail) unless an earlier run finished the stage.
  template <class Body>
  void stage(const std::string& name, Body&& body);
  std::function<void(size_t, size_t)> progress_of(const std::string& stage, const std::string& unit) const;
  void note(const std::string& line) const {
    if (a.log) a.log(line);
  }

  std::string world_stage();
  std::string buffers_stage();
  std::string frames_stage();
  std::string lift_stage();
  std::string gsm_lift_stage(const render::FramesMeta& meta);
  std::string preview_stage();
  void write_trajectory() const;
  void write_manifest() const;

  const GenerateArgs& a;
  scene::Diagnostics& diag;
  CameraPath cp;
  const render::Trajectory* traj = nullptr;
  render::AppearancePrompt prompt;
  nlohmann::ordered_json inputs, options;
  std::string fingerprint;
  GenerateResult result;
  std::optional<PackageStaging> staging;
  std::optional<scene::PackageLayout> pkg;  // the staging folder's
  // Stage 2 and 3's shared state: the static scene (uploaded once) and the car mesh.
  world::TriangleMesh mesh = world::builtin_car_mesh();
  std::optional<world::VoxelGrid> static_world;
  std::optional<gpu::Context> ctx;
  std::optional<render::OverlayWorld> overlay;
  std::optional<lift::GsmLiftModel> gsm_model;  // Stage 3's learned model, loaded and checked with the inputs
  render::OverlayWorld& shared_overlay() {
    if (!overlay) overlay.emplace(*ctx, *static_world);
    return *overlay;
  }
};

void GenerateJob::check_inputs() {
  if (a.path.scene.empty()) throw std::invalid_argument("give the SCENE");
  if (a.output.empty()) throw std::invalid_argument("give -o PACKAGE");
  scene::refuse_overwriting_input(a.path.scene, a.output);
  if (!a.world.empty()) scene::refuse_overwriting_input(a.world, a.output);
  if (!a.frames_from.empty()) scene::refuse_overwriting_input(a.frames_from, a.output);
  if (!a.sky_masks.empty() && a.frames_from.empty())
    throw std::invalid_argument("--sky-masks goes with --frames-from (masks segmented from those frames)");
  if (!a.sky_masks.empty()) scene::refuse_overwriting_input(a.sky_masks, a.output);
  cp = resolve_camera_path(a.path, diag);
  if (cp.passes.size() != 1)
    throw std::invalid_argument("generate takes one camera pass; the trajectory file holds " +
                                std::to_string(cp.passes.size()));
  traj = &cp.passes[0];
  prompt = render::parse_prompt(a.prompt);  // a bad prompt is refused before any stage
  if (!a.frames_from.empty() && fs::is_directory(a.frames_from)) {  // before any stage: one frame per camera pose
    const size_t n = render::png_files(a.frames_from).size();
    if (n != traj->size())
      throw scene::InputError(a.frames_from, "", std::to_string(n) + " .png frames, but the camera path has " +
                                                     std::to_string(traj->size()) + " frames; frames are matched by index");
  } else if (!a.frames_from.empty() && !fs::is_regular_file(a.frames_from)) {
    throw scene::InputError(a.frames_from, "", "neither a folder of PNG frames nor a video file");
  }
  if (!a.gsm.weights.empty()) {  // the learned lift: its configuration, sizes and weights before any stage
    for (const std::string& f : {a.gsm.config, a.gsm.weights}) scene::refuse_overwriting_input(f, a.output);
    const nn::GsmModelConfig config = lift::load_gsm_lift_config(a.gsm);
    lift::GsmLiftOptions o = a.gsm_options;
    o.key_every = a.key_every;
    o.pixel_frames = a.pixel_frames;
    if (!o.cpu_reference) {  // the device's storage-binding size bounds the key frames' size
      if (!ctx) ctx.emplace(gpu::ContextOptions::from_env());
      o.max_view_pixels = lift::gsm_max_view_pixels(ctx->info().max_storage_buffer_range);
    }
    lift::gsm_lift_plan(traj->size(), cp.K.width, cp.K.height, a.path.scene, config.config, o);
    gsm_model.emplace(lift::load_gsm_lift_model(a.gsm));
  }
  if (!a.sky_masks.empty()) {  // before any stage too: one mask per camera pose (sizes: the import)
    const size_t n = render::png_files(a.sky_masks).size();
    if (n != traj->size())
      throw scene::InputError(a.sky_masks, "", std::to_string(n) + " sky masks, but the camera path has " +
                                                   std::to_string(traj->size()) + " frames; masks are matched by index");
  }
}

// What the package is made of; its SHA-256 decides whether a staging folder may be resumed.
void GenerateJob::fingerprint_inputs() {
  inputs = {{"scene", a.path.scene}, {"scene_sha256", scene::sha256_file(a.path.scene)}};
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
  if (!a.gsm.weights.empty()) {
    const bool preset = a.gsm.config == nn::kInfinicubeGsmPreset;  // the name wins over a file of that name
    inputs["gsm_config"] = a.gsm.config;
    inputs["gsm_config_sha256"] = preset ? std::string("preset") : scene::sha256_file(a.gsm.config);
    inputs["gsm_weights"] = a.gsm.weights;
    inputs["gsm_weights_sha256"] = scene::sha256_file(a.gsm.weights);
  }
  if (!a.path.trajectory.empty()) {
    inputs["trajectory"] = a.path.trajectory;
    inputs["trajectory_sha256"] = scene::sha256_file(a.path.trajectory);
  }
  options = {{"prompt", a.prompt},       {"seed", a.seed},
             {"frames", a.path.frames},  {"camera", {cp.K.fx, cp.K.fy, cp.K.cx, cp.K.cy, cp.K.width, cp.K.height}},
             {"route_m", a.path.route_m}, {"key_every", a.key_every},
             {"gaussians_per_cell", a.per_cell}, {"pixel_frames", a.pixel_frames}, {"videos", !a.no_video},
             {"video_preset", a.video_preset}, {"preview", !a.no_preview}};
  if (!a.gsm.weights.empty())
    options["gsm"] = {{"input_size", {a.gsm_options.width, a.gsm_options.height}},
                      {"radius_m", a.gsm_options.radius},
                      {"backend", a.gsm_options.cpu_reference ? "cpu" : "gpu"}};
  fingerprint = scene::sha256_hex(inputs.dump() + "\n" + options.dump());
}

template <class Body>
void GenerateJob::stage(const std::string& name, Body&& body) {
  if (const std::string* detail = staging->finished(name)) {
    result.stages.push_back({name, *detail, 0.0, peak_rss_mib(), true});
    return;
  }
  const auto t0 = Clock::now();
  const std::string detail = body();
  result.stages.push_back({name, detail, std::chrono::duration<double>(Clock::now() - t0).count(), peak_rss_mib(), false});
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.1f", result.stages.back().seconds);
  note("[" + name + "] " + seconds + " s: " + detail);
  staging->finish(name, detail);
  if (a.on_stage_finished) a.on_stage_finished(name);
}

std::function<void(size_t, size_t)> GenerateJob::progress_of(const std::string& stage, const std::string& unit) const {
  if (!a.progress) return {};
  return [this, stage, unit](size_t done, size_t total) { a.progress(stage, unit, done, total); };
}

// Stage 1: the voxel world, and the scene as read (map, tracks, ego, cameras) in the icube JSON: icube-view
// PACKAGE drives its ego track and shows its cars in the voxel views; icube buffers / lidar take it as --scene.
std::string GenerateJob::world_stage() {
  const scene::Scene& sc = *cp.scene;
  const world::VoxelGrid w = [&] {
    if (!a.world.empty()) return world::load_world(a.world);
    const world::ProceduralPrior prior(sc);
    world::WorldBuildOptions wo;
    wo.seed = a.seed;
    wo.progress = progress_of("world", "chunks");
    world::WorldBuildResult r = world::build_world(sc, prior, wo);
    for (const std::string& n : r.plan.notes) diag.warn(a.path.scene, "plan", n);
    return std::move(r.world);
  }();
  world::save_world(w, pkg->world().string());
  scene::write_scene_json(sc, pkg->scene().string());
  return std::to_string(w.voxel_count()) + " voxels in " + std::to_string(w.brick_count()) + " bricks (" +
         (a.world.empty() ? std::string("procedural") : a.world) + ")";
}

// Stage 2a: the guidance buffers in InfiniCube's layout, and their contact sheet.
std::string GenerateJob::buffers_stage() {
  const scene::Scene& sc = *cp.scene;
  fs::remove_all(pkg->buffers());  // what a killed run left half-written
  render::SequenceOptions so;
  so.seed = a.seed;
  so.progress = progress_of("buffers", "frames");
  const render::GuidanceSequence seq = render::render_sequence(*ctx, shared_overlay(), &sc, mesh, cp.K, *traj, so);
  fs::create_directories(pkg->clip());
  render::Stage2Options wo;
  wo.clip = scene::PackageLayout::kClip;
  wo.videos = !a.no_video;
  wo.video.preset = a.video_preset;
  const render::Stage2Result wr =
      render::write_stage2(seq, &sc, render::world_to_voxel_world(traj->c2w[0]), pkg->clip().string(), wo);
  for (const std::string& n : wr.notes) diag.warn(a.output, "buffers", n);
  render::write_contact_sheet(pkg->contact_sheet().string(),
                              render::contact_sheet(seq, wo.clip + ": " + std::to_string(seq.frames.size()) + " frames"));
  return std::to_string(traj->size()) + " frames " + std::to_string(cp.K.width) + "x" + std::to_string(cp.K.height);
}

// The camera path in our world frame, pose i = package frame i, with the frames' scene times when they
// have them (the frames of gaussians/scene.json then: icube splat render --trajectory places the cars).
void GenerateJob::write_trajectory() const {
  bool timed = !traj->time_index.empty();
  for (int t : traj->time_index) timed = timed && t >= 0;
  scene::write_file_atomic(pkg->trajectory().string(),
                           render::trajectory_json(traj->c2w, cp.K, timed ? &traj->time_index : nullptr));
}

// Stage 2b: the appearance frames, rendered or imported (a video model's).
std::string GenerateJob::frames_stage() {
  const fs::path fdir = pkg->frames();
  fs::remove_all(fdir);
  fs::remove(pkg->trajectory());
  fs::create_directories(fdir);
  if (!a.frames_from.empty()) {
    render::FramesImportOptions io;
    io.prompt = a.prompt;
    io.sky_masks = a.sky_masks;
    io.sky_label = a.sky_label;
    const render::FramesImportReport rep = render::import_frames(a.frames_from, pkg->clip().string(), fdir.string(), io);
    for (const std::string& n : rep.notes) diag.warn(a.frames_from, "frames", n);
    write_trajectory();
    return "imported " + std::to_string(rep.frames) + " frames from " + a.frames_from + (rep.rescaled ? " (rescaled)" : "");
  }
  render::FramesRenderOptions fo;
  fo.seed = a.seed;
  fo.progress = progress_of("frames", "frames");
  render::render_frames(*ctx, shared_overlay(), *static_world, &*cp.scene, mesh, cp.K, *traj, a.prompt, fo, fdir.string());
  write_trajectory();
  return prompt.summary();
}

// Stage 3: the static Gaussians, the moving cars and the sky from the frames.
std::string GenerateJob::lift_stage() {
  fs::remove_all(pkg->gaussians());
  const render::FramesMeta meta = render::read_frames_meta(pkg->frames().string());
  if (gsm_model) return gsm_lift_stage(meta);
  lift::LiftFramesOptions lo;
  lo.key_every = a.key_every;
  lo.lift.per_cell = a.per_cell;
  lo.pixel_frames = a.pixel_frames;
  lo.scene = &*cp.scene;
  lo.car_mesh = &mesh;
  const auto lift_progress = progress_of("lift", "frames");
  lo.progress = [&](const char* what, size_t done, size_t total) {
    if (lift_progress && std::string(what) == "lift") lift_progress(done, total);
  };
  const lift::LiftFramesResult lr = lift::lift_frames(*ctx, *static_world, pkg->frames().string(), meta, lo);
  lift::write_lift_outputs(pkg->gaussians().string(), meta, lr, lo);
  char detail[256];
  std::snprintf(detail, sizeof detail,
                "%zu static Gaussians (%zu of %zu mid-ground pixels), %zu dynamic objects (%zu Gaussians), "
                "held-out PSNR %.2f dB over %zu frames",
                lr.cloud.size(), lr.pixel.gaussians, lr.pixel.pixels, lr.objects.size(), lr.object_gaussians(), lr.mean_psnr(),
                lr.eval.size());
  return detail;
}

// Stage 3 with the learned GSM: the same files.
std::string GenerateJob::gsm_lift_stage(const render::FramesMeta& meta) {
  lift::GsmLiftOptions o = a.gsm_options;
  o.key_every = a.key_every;
  o.pixel_frames = a.pixel_frames;
  o.scene = &*cp.scene;
  o.car_mesh = &mesh;
  const auto lift_progress = progress_of("lift", "GSM stages");
  o.progress = [&](const char* what, size_t done, size_t total) {
    if (lift_progress && std::string(what) == "gsm") lift_progress(done, total);
  };
  const lift::GsmLiftResult r =
      lift::gsm_lift_frames(*ctx, *static_world, pkg->world().string(), pkg->frames().string(), meta, *gsm_model, o);
  lift::write_gsm_lift_outputs(pkg->gaussians().string(), meta, r, o);
  char detail[256];
  std::snprintf(detail, sizeof detail,
                "GSM: %zu static Gaussians (%zu voxel, %zu pixel) from %zu key frames at %ux%u and %zu voxels, %zu dynamic "
                "objects (%zu Gaussians), held-out PSNR %.2f dB over %zu frames",
                r.lift.cloud.size(), r.gsm.voxel_gaussians, r.gsm.pixel_gaussians, r.gsm.views, r.gsm.width, r.gsm.height,
                r.gsm.input_voxels, r.lift.objects.size(), r.lift.object_gaussians(), r.lift.mean_psnr(), r.lift.eval.size());
  return detail;
}

// The preview: the Gaussians along the trajectory (mp4 with videos) and a sheet against the frames.
std::string GenerateJob::preview_stage() {
  fs::remove_all(pkg->preview());
  if (a.no_preview) return "skipped (--no-preview)";
  const render::FramesMeta meta = render::read_frames_meta(pkg->frames().string());
  const splat::SplatScene gs = splat::read_splat_scene(pkg->splat_scene().string());
  const splat::SkyImage sky = splat::read_sky_png(pkg->sky().string());
  lift::FlythroughOptions fo;
  fo.video = !a.no_video;
  fo.mp4.preset = "medium";  // a fly-through for people, not an input of InfiniCube's models: 3-4x faster than veryslow
  fo.progress = progress_of("preview", "frames");
  const lift::FlythroughResult fr =
      lift::write_flythrough(*ctx, gs, sky, meta, pkg->frames().string(), pkg->preview().string(), fo);
  char detail[160];
  std::snprintf(detail, sizeof detail, "%zu frames of the Gaussians (%.0f drawn per frame)%s", fr.frames, fr.mean_gaussians,
                fo.video ? ", flythrough.mp4" : "");
  return detail;
}

// The manifest: inputs, options, stages, and every file's SHA-256 (itself excluded).
void GenerateJob::write_manifest() const {
  nlohmann::ordered_json m;
  m["format"] = scene::kPackageFormat;
  m["version"] = scene::kPackageVersion;
  m["fingerprint"] = fingerprint;
  m["inputs"] = inputs;
  m["options"] = options;
  m["frames"] = traj->size();
  nlohmann::ordered_json st = nlohmann::ordered_json::array();
  for (const GenerateStage& s : result.stages) st.push_back({{"stage", s.name}, {"detail", s.detail}});
  m["stages"] = st;  // times and memory are printed, not stored: the same inputs give the same bytes
  nlohmann::ordered_json files = nlohmann::ordered_json::object();
  for (const std::string& f : package_files(pkg->root())) files[f] = scene::sha256_file((pkg->root() / f).string());
  m["files"] = files;
  scene::write_file_atomic(pkg->manifest().string(), m.dump(1) + "\n");
}

GenerateResult GenerateJob::run() {
  const auto t_start = Clock::now();
  check_inputs();
  fingerprint_inputs();
  result.package = fs::absolute(a.output);
  if (a.resume && fs::exists(result.package)) {
    const scene::PackageCheck done = scene::check_package(result.package.string());
    if (done.complete && done.fingerprint == fingerprint) {
      result.skipped = true;
      result.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
      return result;
    }
    note("icube: note: " + result.package.string() + ": " +
         (done.complete ? "made with other inputs or options" : done.problem) + "; generating it again");
  }
  staging.emplace(result.package, fingerprint, a.resume);
  pkg.emplace(staging->path());
  result.resumed_stages = staging->resumed_stages();
  if (result.resumed_stages)
    note("generate: resuming " + staging->path().string() + " after stage '" + generate_stage_names()[result.resumed_stages - 1] + "'");

  stage("world", [&] { return world_stage(); });  // read back from the staging folder when resumed
  const world::VoxelGrid world = world::load_world(pkg->world().string());
  const int t0_index = traj->time_index.empty() ? 0 : std::max(0, traj->time_index[0]);
  static_world.emplace(render::make_static_world(world, *cp.scene, t0_index, mesh));
  if (!ctx) ctx.emplace(gpu::ContextOptions::from_env());
  stage("buffers", [&] { return buffers_stage(); });
  stage("frames", [&] { return frames_stage(); });
  overlay.reset();  // the lift casts against its own copies of the world
  stage("lift", [&] { return lift_stage(); });
  stage("preview", [&] { return preview_stage(); });
  write_manifest();
  staging->commit();
  result.seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
  return result;
}

}  // namespace

GenerateResult generate_package(const GenerateArgs& a, scene::Diagnostics& diag) { return GenerateJob(a, diag).run(); }

}  // namespace icube::pipeline
