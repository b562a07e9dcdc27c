// `icube lidar`: a spinning LiDAR swept along the scene's ego track against a
// voxel world (dynamic cars per frame, as `icube buffers`), written as PLY,
// KITTI .bin, range-image PNGs and sensor poses.
//
//   icube lidar WORLD --scene SCENE [--record SEL] [--preset waymo-top]
//               [--beams N] [--elevation MIN:MAX | --elevations e0,e1,...]
//               [--columns N] [--range MIN:MAX] [--mount-height M]
//               [--start-azimuth DEG] [--frames A:B] [--ply-world] -o OUTDIR
//   icube lidar --gaussians SPLATS (--scene SCENE | --trajectory POSES.npy)
//               [--gs-range median|expected] [--alpha-threshold A] [model and
//               frame options as above] -o OUTDIR
//
// With --gaussians the sweeps are cast against 3D Gaussians (a 3DGS .ply,
// a .splat, or a splat scene .json with dynamic objects: splat/splat_scene.h,
// composed per sweep at the frame's scene state) instead of a voxel world (engine/splat/lidar_gaussians_gpu.h; range
// = median (default) or expected depth of the front-to-back composite, a
// return when the accumulated alpha >= --alpha-threshold (default 0.5),
// intensity = the blend-weighted luminance of the Gaussians' DC colour;
// class/instance 0). Sensor poses: the scene's ego track with the mount, as
// for voxels, or --trajectory: a float32/float64 [N,4,4] .npy of
// SENSOR-TO-WORLD matrices (FLU sensor axes, row-major: exactly the
// poses.npy an earlier `icube lidar` run writes; --mount-height does not
// apply), frame i = position i, scene state min(i, frames − 1) of a splat
// scene with objects (as `icube buffers` does for recorded poses).
//
// Model: the preset (waymo-top, lidar_model.h), then the overrides: --beams
// and/or --elevation give uniform beams (the missing one from the preset),
// --elevations an explicit list; --mount-height puts the sensor M metres
// above the ego origin. --frames selects positions of the ego track like
// `icube buffers`. Every option is checked before anything is read or
// written. Output (lidar_io.h) is built in a hidden staging folder next to
// OUTDIR and renamed into place at the end, so a failure leaves nothing
// half-written; an existing OUTDIR is replaced only if it is empty or an
// earlier `icube lidar` output (has lidar.json).
// Engine: engine/render/lidar/.
#include "cli_common.h"
#include "command_registry.h"
#include "progress.h"
#include "staging_dir.h"

#include "gpu/context.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"
#include "render/buffers/trajectory.h"
#include "render/lidar/lidar_io.h"
#include "render/lidar/lidar_model.h"
#include "render/lidar/lidar_sequence.h"
#include "splat/lidar_gaussian_sequence.h"
#include "scene/atomic_file.h"
#include "splat/lidar_gaussians_gpu.h"
#include "splat/splat_scene.h"
#include "scene/scene_load.h"
#include "world/car_mesh.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

namespace icube::tools {

namespace {

namespace fs = std::filesystem;

struct LidarArgs {
  std::string world, scene, record, preset = "waymo-top", beams, elevation, elevations, columns, range, mount_height,
      start_azimuth, frames, output;
  std::string gaussians, trajectory, gs_range, alpha_threshold;  // Gaussian mode
  bool ply_world = false;
};

uint32_t parse_count(const std::string& s, const char* option, uint32_t max) {
  char* end = nullptr;
  const long long v = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || v < 1 || v > static_cast<long long>(max))
    throw std::invalid_argument(std::string(option) + ": expected an integer in 1.." + std::to_string(max) + ", got '" +
                                s + "'");
  return static_cast<uint32_t>(v);
}

double parse_real(const std::string& s, const char* option) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !std::isfinite(v))
    throw std::invalid_argument(std::string(option) + ": expected a number, got '" + s + "'");
  return v;
}

render::LidarModel model_from_args(const LidarArgs& a) {
  render::LidarModel m = render::lidar_preset(a.preset);
  if (!a.elevations.empty() && (!a.beams.empty() || !a.elevation.empty()))
    throw std::invalid_argument("give --elevations, or --beams / --elevation, not both");
  if (!a.elevations.empty()) m.elevations_deg = render::parse_elevation_list(a.elevations);
  if (!a.beams.empty() || !a.elevation.empty()) {
    const uint32_t beams = a.beams.empty() ? m.beams() : parse_count(a.beams, "--beams", 65535);
    double lo = m.elevations_deg.back(), hi = m.elevations_deg.front();
    if (!a.elevation.empty()) render::parse_min_max(a.elevation, "--elevation", &lo, &hi);
    m.elevations_deg = render::uniform_elevations(beams, lo, hi);
  }
  if (!a.columns.empty()) m.columns = parse_count(a.columns, "--columns", 65535);
  if (!a.range.empty()) render::parse_min_max(a.range, "--range", &m.min_range, &m.max_range);
  if (!a.mount_height.empty()) {
    const double h = parse_real(a.mount_height, "--mount-height");
    if (std::fabs(h) > 100.0) throw std::invalid_argument("--mount-height: expected metres in -100..100");
    m.sensor_to_ego[3].z = h;
  }
  if (!a.start_azimuth.empty()) m.start_azimuth_deg = parse_real(a.start_azimuth, "--start-azimuth");
  render::validate_lidar(m);
  return m;
}

// OUTDIR may be replaced: absent, an empty folder, or an earlier lidar output.
void check_output(const fs::path& out) {
  std::error_code ec;
  if (!fs::exists(out, ec)) return;
  if (!fs::is_directory(out, ec)) throw std::runtime_error(out.string() + ": exists and is not a folder");
  if (fs::is_empty(out, ec) || fs::exists(out / "lidar.json", ec)) return;
  throw std::runtime_error(out.string() + ": exists and is not an earlier `icube lidar` output (no lidar.json); "
                                          "choose another -o or remove it");
}

void cmd_lidar_gaussians(const LidarArgs& a, scene::Diagnostics& diag) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  if (!a.world.empty()) throw std::invalid_argument("give a WORLD or --gaussians FILE, not both");
  if (a.scene.empty() == a.trajectory.empty())
    throw std::invalid_argument("--gaussians needs exactly one of --scene SCENE or --trajectory POSES.npy");
  if (!a.trajectory.empty() && !a.record.empty()) throw std::invalid_argument("--record needs --scene");
  if (!a.trajectory.empty() && !a.mount_height.empty())
    throw std::invalid_argument("--mount-height does not apply to --trajectory (its poses are sensor poses)");
  const render::LidarModel model = model_from_args(a);
  splat::LidarGaussianOptions go;
  if (!a.gs_range.empty()) {
    if (a.gs_range == "median") go.range = splat::LidarRangeMode::Median;
    else if (a.gs_range == "expected") go.range = splat::LidarRangeMode::Expected;
    else throw std::invalid_argument("--gs-range: expected 'median' or 'expected', got '" + a.gs_range + "'");
  }
  if (!a.alpha_threshold.empty()) {
    go.alpha_threshold = parse_real(a.alpha_threshold, "--alpha-threshold");
    if (!(go.alpha_threshold > 0.0 && go.alpha_threshold <= 1.0))
      throw std::invalid_argument("--alpha-threshold: expected a number in (0, 1], got '" + a.alpha_threshold + "'");
  }
  std::optional<render::FrameRange> range;
  if (!a.frames.empty()) range = render::parse_frame_range(a.frames);
  if (a.output.empty()) throw std::invalid_argument("-o OUTDIR is empty");
  fs::path out = fs::absolute(a.output).lexically_normal();
  if (out.filename().empty()) out = out.parent_path();
  check_output(out);

  const auto t_read = Clock::now();
  const splat::SplatScene gs = splat::read_splat_scene(a.gaussians);
  const double read_s = std::chrono::duration<double>(Clock::now() - t_read).count();
  render::Trajectory traj;
  std::string pose_source;
  if (!a.scene.empty()) {
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    const scene::Scene sc = scene::load_scene(a.scene, lo, &diag);
    if (sc.ego.empty()) throw scene::InputError(a.scene, "ego", "the scene has no ego trajectory");
    traj = render::lidar_ego_trajectory(sc, model.sensor_to_ego);
    if (traj.size() == 0) throw scene::InputError(a.scene, "ego", "no valid ego pose");
    pose_source = a.scene;
  } else {
    render::TrajectoryFile tf = render::load_trajectory(a.trajectory, gs.frames());
    if (tf.passes.size() != 1)
      throw scene::InputError(a.trajectory, "shape", "expected one pass of [N,4,4] sensor-to-world poses");
    traj = std::move(tf.passes[0]);
    pose_source = a.trajectory;
  }
  if (range) traj = render::select_frames(traj, *range);

  gpu::Context ctx(gpu::ContextOptions::from_env());
  splat::LidarGaussiansGpu caster(ctx, model);
  StagingDir staging(out.parent_path(), out.filename().string());

  ProgressBar bar("lidar", "frames");
  render::LidarWriteOptions wo;
  wo.world_frame_ply = a.ply_world;
  const std::string returns_when = "a return when the accumulated alpha >= " + std::to_string(go.alpha_threshold);
  wo.range_convention = go.range == splat::LidarRangeMode::Median
                            ? "Gaussians: median depth (t* where the front-to-back transmittance first falls to <= 0.5); " +
                                  returns_when
                            : "Gaussians: expected depth (blend-weighted mean t*); " + returns_when;
  wo.intensity_convention = "Gaussians: blend-weighted mean of each Gaussian's DC-colour luminance, [0, 1]; class and instance 0";
  splat::LidarGaussianSequenceOptions so;
  so.cast = go;
  so.progress = [&](size_t done, size_t total) { bar.update(done, total); };
  so.on_frame = [&](const render::LidarScan& s) { render::write_lidar_frame(staging.path.string(), s, model, wo); };
  const splat::LidarGaussianSequenceStats st = splat::cast_lidar_gaussian_sequence(caster, gs, traj, so);
  double write_s = st.sink_s;
  const auto t0 = Clock::now();
  scene::write_file_atomic((staging.path / "poses.npy").string(), render::lidar_poses_npy(traj.c2w));
  scene::write_file_atomic((staging.path / "lidar.json").string(),
                           render::lidar_meta_json(model, traj.frame_index, wo, a.gaussians + " + " + pose_source));
  write_s += std::chrono::duration<double>(Clock::now() - t0).count();

  if (fs::exists(out)) fs::remove_all(out);
  fs::rename(staging.path, out);
  staging.keep = true;
  const double total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
  const double mrays = static_cast<double>(model.rays() * traj.size()) * 1e-6;
  std::printf("lidar: %zu Gaussians (%zu objects), %zu frames, %u beams x %u columns, %.2f Mrays, %llu returns "
              "(%.1f %%), %.2f s, %.2f Mrays/s casting (%.2f overall) [read %.2f s, compose + upload %.2f s, cast %.2f s "
              "(GPU %.2f ms), %.1f tile instances per frame, write %.2f s] -> %s\n",
              st.max_gaussians, gs.objects.size(), traj.size(), model.beams(), model.columns, mrays,
              static_cast<unsigned long long>(st.returns),
              mrays > 0 ? 100.0 * static_cast<double>(st.returns) * 1e-6 / mrays : 0.0, total_s,
              st.cast_s > 0 ? mrays / st.cast_s : 0.0, total_s > 0 ? mrays / total_s : 0.0, read_s, st.compose_s, st.cast_s,
              st.gpu_ms, traj.size() ? static_cast<double>(st.instances) / static_cast<double>(traj.size()) : 0.0, write_s,
              out.string().c_str());
  if (st.culled_sweeps)
    std::printf("lidar: the set is over the %llu Gaussians one upload takes on this device: %zu sweeps cast the "
                "Gaussians within %.0f m of the sensor (the same scan)\n",
                static_cast<unsigned long long>(caster.max_gaussians()), st.culled_sweeps, model.max_range);
}

void cmd_lidar(const LidarArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    if (!a.gaussians.empty()) {
      cmd_lidar_gaussians(a, diag);
      return;
    }
    if (a.world.empty()) throw std::invalid_argument("give a WORLD file (.icw) or --gaussians FILE");
    if (a.scene.empty()) throw std::invalid_argument("--scene SCENE is required with a WORLD");
    if (!a.trajectory.empty()) throw std::invalid_argument("--trajectory works with --gaussians only");
    if (!a.gs_range.empty() || !a.alpha_threshold.empty())
      throw std::invalid_argument("--gs-range and --alpha-threshold work with --gaussians only");
    using Clock = std::chrono::steady_clock;
    const auto t_start = Clock::now();
    const render::LidarModel model = model_from_args(a);
    std::optional<render::FrameRange> range;
    if (!a.frames.empty()) range = render::parse_frame_range(a.frames);
    if (a.output.empty()) throw std::invalid_argument("-o OUTDIR is empty");
    fs::path out = fs::absolute(a.output).lexically_normal();
    if (out.filename().empty()) out = out.parent_path();
    check_output(out);

    const world::VoxelGrid world = world::load_world(a.world);
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    scene::Scene sc = scene::load_scene(a.scene, lo, &diag);
    if (scene::tracks_unclassified(sc)) scene::classify_tracks(sc);
    if (sc.ego.empty()) throw scene::InputError(a.scene, "ego", "the scene has no ego trajectory");
    render::Trajectory traj = render::lidar_ego_trajectory(sc, model.sensor_to_ego);
    if (traj.size() == 0) throw scene::InputError(a.scene, "ego", "no valid ego pose");
    if (range) traj = render::select_frames(traj, *range);

    // Static scene on the GPU once; dynamic cars per frame.
    const world::TriangleMesh mesh = world::builtin_car_mesh();
    const world::VoxelGrid static_world = render::make_static_world(world, sc, std::max(0, traj.time_index[0]), mesh);
    gpu::Context ctx(gpu::ContextOptions::from_env());
    render::OverlayWorld overlay(ctx, static_world);

    StagingDir staging(out.parent_path(), out.filename().string());

    ProgressBar bar("lidar", "frames");
    render::LidarWriteOptions wo;
    wo.world_frame_ply = a.ply_world;
    double write_s = 0.0;
    render::LidarSequenceOptions so;
    so.progress = [&](size_t done, size_t total) { bar.update(done, total); };
    so.on_frame = [&](const render::LidarScan& s) {
      const auto t0 = Clock::now();
      render::write_lidar_frame(staging.path.string(), s, model, wo);
      write_s += std::chrono::duration<double>(Clock::now() - t0).count();
    };
    const render::LidarSequenceStats st = render::cast_lidar_sequence(ctx, overlay, &sc, mesh, model, traj, so);
    const auto t0 = Clock::now();
    scene::write_file_atomic((staging.path / "poses.npy").string(), render::lidar_poses_npy(traj.c2w));
    scene::write_file_atomic((staging.path / "lidar.json").string(),
                             render::lidar_meta_json(model, traj.frame_index, wo, a.world + " + " + a.scene));
    write_s += std::chrono::duration<double>(Clock::now() - t0).count();

    if (fs::exists(out)) fs::remove_all(out);
    fs::rename(staging.path, out);
    staging.keep = true;
    const double total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
    const double mrays = static_cast<double>(st.rays) * 1e-6;
    std::printf("lidar: %zu frames, %u beams x %u columns, %.2f Mrays, %llu returns (%.1f %%), %.2f s, %.2f Mrays/s ray "
                "casting (%.2f overall) [cast %.2f s, rays up %.2f s, cars %.2f s, overlay %.2f s, readback %.2f s, "
                "returns %.2f s, write %.2f s] -> %s\n",
                st.frames, model.beams(), model.columns, mrays, static_cast<unsigned long long>(st.returns),
                st.rays ? 100.0 * static_cast<double>(st.returns) / static_cast<double>(st.rays) : 0.0, total_s,
                st.cast_s > 0 ? mrays / st.cast_s : 0.0, total_s > 0 ? mrays / total_s : 0.0, st.cast_s, st.upload_s,
                st.cars_s, st.overlay_s, st.download_s, st.post_s, write_s, out.string().c_str());
  });
}

void add_lidar_commands(CLI::App& app) {
  auto a = std::make_shared<LidarArgs>();
  CLI::App* cmd = app.add_subcommand("lidar", "Spinning LiDAR along the ego track: PLY, KITTI .bin, range images");
  cmd->add_option("world", a->world, "World file (.icw); optional with --gaussians")->type_name("WORLD");
  cmd->add_option("--gaussians", a->gaussians,
                  "Cast against 3D Gaussians (.ply, .splat or a splat scene .json) instead of a voxel world")
      ->type_name("FILE");
  cmd->add_option("--scene", a->scene, "Scene: ego trajectory, static and dynamic cars")->type_name("SCENE");
  cmd->add_option("--trajectory", a->trajectory,
                  "--gaussians only: sensor-to-world poses (.npy [N,4,4], FLU sensor axes, like poses.npy)")
      ->type_name("POSES.npy");
  cmd->add_option("--gs-range", a->gs_range, "--gaussians only: range = median (default) or expected depth")
      ->type_name("MODE");
  cmd->add_option("--alpha-threshold", a->alpha_threshold,
                  "--gaussians only: a return when the accumulated alpha >= A (default 0.5)")
      ->type_name("A");
  cmd->add_option("--record", a->record, "Waymo TFRecord only: which record, by index or scenario id")->type_name("SEL");
  cmd->add_option("--preset", a->preset, "Sensor preset: waymo-top (64 beams, +2.4..-17.6 deg, 2650 columns, 75 m)")
      ->type_name("NAME")
      ->capture_default_str();
  cmd->add_option("--beams", a->beams, "Number of beams, spaced uniformly over --elevation")->type_name("N");
  cmd->add_option("--elevation", a->elevation, "Vertical field of view in degrees (uniform beams)")->type_name("MIN:MAX");
  cmd->add_option("--elevations", a->elevations, "Explicit beam elevations in degrees")->type_name("e0,e1,...");
  cmd->add_option("--columns", a->columns, "Azimuth steps per rotation")->type_name("N");
  cmd->add_option("--range", a->range, "Returns kept between MIN and MAX metres")->type_name("MIN:MAX");
  cmd->add_option("--mount-height", a->mount_height, "Sensor height above the ego origin, metres")->type_name("M");
  cmd->add_option("--start-azimuth", a->start_azimuth, "Azimuth of column 0's leading edge, degrees (CCW from forward)")
      ->type_name("DEG");
  cmd->add_option("--frames", a->frames, "Frames [A, B) of the ego track (A:, :B, A and A:B:S also work)")->type_name("A:B");
  cmd->add_flag("--ply-world", a->ply_world, "PLY points in the world frame instead of the sensor frame");
  cmd->add_option("-o,--output", a->output, "Output folder (ply/, bin/, range/, range_color/, poses.npy, lidar.json)")
      ->required()
      ->type_name("OUTDIR");
  cmd->footer(
      "Each sweep is cast from the frame's ego pose (motion during the rotation is ignored) with the voxel ray caster: "
      "range = entry of the first >= 0.1 m run of voxels, class/instance = the first voxel with a >= 1 cm chord, "
      "intensity = per-class reflectivity x |cos(incidence)|. The world's vehicle voxels are replaced by the scene's "
      "cars (static once, dynamic per frame), as in `icube buffers`. With --gaussians: every Gaussian's peak along the "
      "ray (t*, alpha = min(0.99, opacity x response)), composited front to back (skip alpha < 1/255, stop at T < "
      "1e-4); range = median or expected depth, intensity = blend-weighted DC-colour luminance.");
  cmd->callback([a] { cmd_lidar(*a); });
}

const CommandRegistrar kLidarRegistrar(add_lidar_commands, 46);

}  // namespace

}  // namespace icube::tools
