// `icube buffers` (Stage 2): renders a voxel world's guidance buffers
// (semantic, instance, depth, coordinate, optional normals) along a camera
// trajectory into InfiniCube's Stage-2 clip layout, plus a contact sheet.
//
//   icube buffers WORLD [--scene SCENE] [--record SEL] [--trajectory FILE]
//                 [--camera fx,fy,cx,cy,w,h | --camera-preset waymo-front-480p]
//                 [--route METRES [--route-seed N] [--route-speed MPS] [--route-start-lane ID]]
//                 [--frames A:B[:S]] [--seed N] [--pixel-centres] [--normals]
//                 [--object-info moving|observed] [--no-video | --video-preset NAME]
//                 [--clip NAME] -o OUTDIR
//
// Trajectory: --trajectory (.npy [N,4,4] / [P,N,4,4] or icube-trajectory
// JSON, OpenCV camera-to-world in the scene's world frame), or --route (a
// seeded drive along the scene's lanes, render/buffers/trajectory.h
// route_trajectory), else the scene's ego track with its first camera. Camera: --camera, --camera-preset, the
// trajectory JSON's camera, the scene's first camera, else waymo-front-480p.
// Output: OUTDIR/<clip>/ (pass_<k>/ per pass for [P,N,4,4]) is built in a
// hidden staging folder and renamed into place at the end, so a failure
// leaves nothing half-written; OUTDIR/contact_sheet.png. Frames are numbered
// 0 ... N-1 as written; buffers_meta.json keeps each one's trajectory index.
// The field-by-field layout and the official reader of each: docs/guidance-buffers.md.
// Engine: engine/render/buffers/ (guidance_sequence.h, stage2_writer.h).
#include "camera_path_options.h"
#include "cli_common.h"
#include "command_registry.h"
#include "progress.h"
#include "staging_dir.h"

#include "gpu/context.h"
#include "render/buffers/contact_sheet.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/guidance_sequence.h"
#include "render/buffers/overlay_world.h"
#include "render/buffers/stage2_writer.h"
#include "render/buffers/trajectory.h"
#include "scene/frames.h"
#include "scene/route.h"
#include "scene/scene_load.h"
#include "video/mp4_writer.h"
#include "world/car_mesh.h"
#include "world/npy.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace icube::tools {

namespace {

namespace fs = std::filesystem;

struct BuffersArgs {
  pipeline::CameraPathArgs path;
  std::string world, clip, output;
  uint64_t seed = 0;
  bool pixel_centres = false, normals = false, no_video = false;
  std::string object_info = "moving";
  std::string video_preset = "veryslow";
};

std::string sanitize_clip(std::string s) {
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) c = '_';
  while (!s.empty() && s.front() == '.') s.erase(s.begin());
  return s.empty() ? std::string("clip") : s;
}

void cmd_buffers(const BuffersArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    using Clock = std::chrono::steady_clock;
    const auto t_start = Clock::now();
    const world::VoxelGrid world = world::load_world(a.world);
    pipeline::CameraPath cp = pipeline::resolve_camera_path(a.path, diag);
    const std::optional<scene::Scene>& sc = cp.scene;
    const scene::Scene* scene_ptr = sc ? &*sc : nullptr;
    std::vector<render::Trajectory>& passes = cp.passes;
    const render::PinholeIntrinsics K = cp.K;
    const std::string clip = sanitize_clip(
        !a.clip.empty() ? a.clip
                        : (sc && !sc->provenance.scenario_id.empty() ? sc->provenance.scenario_id
                                                                      : fs::path(a.world).stem().string()));

    // Static scene, on the GPU once.
    const world::TriangleMesh mesh = world::builtin_car_mesh();
    render::StaticSceneStats sst;
    const int t0_index = passes[0].time_index.empty() ? 0 : std::max(0, passes[0].time_index[0]);
    const world::VoxelGrid static_world =
        sc ? render::make_static_world(world, *sc, t0_index, mesh, &sst) : world;
    gpu::Context ctx(gpu::ContextOptions::from_env());
    render::OverlayWorld overlay(ctx, static_world);

    // Output staging.
    StagingDir staging(a.output, clip);

    const size_t total_frames = cp.total_frames();
    ProgressBar bar("buffers", "frames");
    size_t done_before = 0;
    uint64_t rays = 0;
    double cast_s = 0.0, write_s = 0.0, cars_s = 0.0, overlay_s = 0.0, other_s = 0.0;
    std::vector<std::string> notes;
    std::optional<render::GuidanceSequence> first_seq;
    const glm::dmat4 w2v = render::world_to_voxel_world(passes[0].c2w[0]);
    for (size_t p = 0; p < passes.size(); ++p) {
      render::SequenceOptions so;
      so.pixels = a.pixel_centres ? render::PixelConvention::Centre : render::PixelConvention::Integer;
      so.seed = a.seed;
      so.keep_normals = a.normals;
      so.progress = [&](size_t done, size_t) { bar.update(done_before + done, total_frames); };
      render::GuidanceSequence seq = render::render_sequence(ctx, overlay, scene_ptr, mesh, K, passes[p], so);
      done_before += passes[p].size();
      rays += seq.rays;
      cast_s += seq.cast_s;
      cars_s += seq.cars_s;
      overlay_s += seq.overlay_s;
      other_s += seq.download_s + seq.post_s;
      const fs::path dir = passes.size() > 1 ? staging.path / ("pass_" + std::to_string(p)) : staging.path;
      fs::create_directories(dir);
      render::Stage2Options wo;
      wo.clip = clip;
      wo.videos = !a.no_video;
      wo.video.preset = a.video_preset;
      wo.object_info = a.object_info == "observed" ? render::ObjectInfoMode::Observed : render::ObjectInfoMode::Moving;
      wo.normals = a.normals;
      const render::Stage2Result wr = render::write_stage2(seq, scene_ptr, w2v, dir.string(), wo);
      write_s += wr.write_s + wr.video_s;
      if (p == 0) notes = wr.notes;
      if (p == 0) first_seq = std::move(seq);
    }
    if (passes.size() > 1) {
      std::vector<float> all;
      for (const auto& p : passes)
        for (const glm::dmat4& c2w : p.c2w) {
          const glm::dmat4 m = w2v * c2w;
          for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) all.push_back(static_cast<float>(m[c][r]));
        }
      bool same = true;
      for (const auto& p : passes) same = same && p.size() == passes[0].size();
      if (same)
        world::write_npy((staging.path / "multi_pass_camera_poses.npy").string(),
                         world::NpyArray::make<float>({passes.size(), passes[0].size(), 4, 4}, all));
    }
    // Into place.
    const fs::path final_dir = fs::path(a.output) / clip;
    if (fs::exists(final_dir)) fs::remove_all(final_dir);
    fs::rename(staging.path, final_dir);
    staging.keep = true;
    const std::string sheet_path = (fs::path(a.output) / "contact_sheet.png").string();
    render::write_contact_sheet(sheet_path, render::contact_sheet(*first_seq, clip + ": " + std::to_string(first_seq->frames.size()) +
                                                                           " frames, " + std::to_string(K.width) + "x" +
                                                                           std::to_string(K.height)));
    for (const std::string& n : notes) diag.warn(a.output, "", n);
    const double total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
    std::printf("buffers: %zu frames %ux%u, %.2f Mrays, %.2f s, %.2f Mrays/s ray casting (%.2f overall), %.2f frames/s "
                "[cast %.2f s, cars %.2f s, overlay %.2f s, readback %.2f s, write %.2f s] -> %s\n",
                total_frames, K.width, K.height, static_cast<double>(rays) * 1e-6, total_s,
                cast_s > 0 ? static_cast<double>(rays) * 1e-6 / cast_s : 0.0,
                total_s > 0 ? static_cast<double>(rays) * 1e-6 / total_s : 0.0,
                total_s > 0 ? static_cast<double>(total_frames) / total_s : 0.0, cast_s, cars_s, overlay_s, other_s,
                write_s, final_dir.string().c_str());
  });
}

void add_buffers_commands(CLI::App& app) {
  auto a = std::make_shared<BuffersArgs>();
  CLI::App* cmd = app.add_subcommand(
      "buffers", "Stage 2: render guidance buffers (semantic, instance, depth, coordinate) along a trajectory");
  cmd->add_option("world", a->world, "World file (.icw)")->required()->type_name("WORLD");
  add_camera_path_options(cmd, a->path);
  cmd->add_option("--seed", a->seed, "Seed of the instance colours and the coordinate-range sampling")
      ->type_name("N")
      ->capture_default_str();
  cmd->add_flag("--pixel-centres", a->pixel_centres, "Rays through pixel centres (u + 0.5) instead of InfiniCube's integer pixels");
  cmd->add_flag("--normals", a->normals, "Also write face-normal PNGs");
  cmd->add_option("--object-info", a->object_info,
                  "dynamic_object_info.tar content: moving = InfiniCube's (the ever-moving vehicles, in every frame, "
                  "ids from 10000); observed = every vehicle, parked ones too, only in frames where it is observed")
      ->check(CLI::IsMember({"moving", "observed"}))
      ->capture_default_str();
  cmd->add_flag("--no-video", a->no_video, "Do not write the three mp4s (semantic, coordinate, depth_vis)");
  cmd->add_option("--video-preset", a->video_preset,
                  "x264 preset of the mp4s (InfiniCube's: veryslow; ultrafast ... veryslow trades time for file size)")
      ->check(CLI::IsMember(video::x264_presets()))
      ->capture_default_str();
  cmd->add_option("--clip", a->clip, "Clip name (default: the scenario id, else the world file's stem)")->type_name("NAME");
  cmd->add_option("-o,--output", a->output, "Output folder (gets <clip>/ and contact_sheet.png)")->required()->type_name("OUTDIR");
  cmd->footer(
      "Per frame the world's vehicle voxels are replaced by the scene's cars voxelised from the built-in car mesh "
      "(static cars once, dynamic cars per frame). Poses are written in InfiniCube's voxel world (first camera's "
      "FLU frame); world_to_voxel_world.npy maps back. Frames are numbered 0..N-1 in every tar, folder and mp4; "
      "buffers_meta.json keeps the trajectory index of each. Layout and readers: docs/guidance-buffers.md.");
  cmd->callback([a] { cmd_buffers(*a); });
}

const CommandRegistrar kBuffersRegistrar(add_buffers_commands, 45);

}  // namespace

}  // namespace icube::tools
