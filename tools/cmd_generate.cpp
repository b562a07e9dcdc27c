// `icube generate` (the main job): scene → Stage 1 voxel world → Stage 2
// guidance buffers and appearance frames → Stage 3 Gaussians and sky, written
// as one package (engine/pipeline/generate_package.h); or a shard of a list of scenes
// (tools/generate_batch.cpp).
//
//   icube generate SCENE -o PACKAGE [--world WORLD.icw] [--prompt TEXT] [--seed N] [--resume]
//                  [--frames A:B[:S]] [--camera ... | --camera-preset NAME | --trajectory F | --route M]
//                  [--key-every N] [--gaussians-per-cell 1|4] [--no-video | --video-preset NAME] [--no-preview]
//                  [--frames-from DIR|VIDEO [--sky-masks DIR [--sky-label N]]] [--pixel-frames N]
//                  [--gsm DIR | --gsm-model CONFIG --gsm-weights W [--gsm-size WxH] [--gsm-radius M] [--gsm-backend B]]
//   icube generate --batch SCENES.txt [--shard I/N] -o OUT_ROOT [the options above]
#include "command_registry.h"
#include "generate_batch.h"
#include "camera_path_options.h"
#include "generate_job.h"
#include "gsm_lift_options.h"
#include "video/mp4_writer.h"

#include "cli_common.h"

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

namespace icube::tools {

namespace {

struct GenerateCommand {
  pipeline::GenerateArgs args;
  std::string batch, shard = "0/1";
  GsmCliArgs gsm;
};

void cmd_generate(const GenerateCommand& c) {
  run_command([&](scene::Diagnostics& diag) {
    pipeline::GenerateArgs args = c.args;
    if (const std::optional<lift::GsmModelPaths> gsm = gsm_paths_of(c.gsm)) {
      args.gsm = *gsm;
      apply_gsm_options(c.gsm, c.args.key_every, args.gsm_options);
      args.key_every = args.gsm_options.key_every;
    }
    if (!c.batch.empty()) {
      if (!c.args.path.scene.empty())
        throw std::invalid_argument("give either a SCENE or --batch SCENES.txt, not both");
      if (!c.args.world.empty()) throw std::invalid_argument("--world gives one scene's world; it cannot go with --batch");
      const size_t failed = run_generate_batch(args, c.batch, parse_shard(c.shard));
      if (failed) throw std::runtime_error(c.batch + ": " + std::to_string(failed) + " scene(s) of this shard failed");
      return;
    }
    if (c.shard != "0/1") throw std::invalid_argument("--shard goes with --batch");
    pipeline::GenerateArgs a = args;
    report_on_terminal(a);
    const pipeline::GenerateResult r = pipeline::generate_package(a, diag);
    if (r.skipped) {
      std::printf("generate: %s is complete (same inputs and options, every file verified); nothing to do\n",
                  r.package.c_str());
      return;
    }
    print_generate_summary(r, c.args.path.scene);
  });
}

void add_generate_command(CLI::App& app) {
  auto c = std::make_shared<GenerateCommand>();
  pipeline::GenerateArgs* a = &c->args;
  CLI::App* cmd = app.add_subcommand(
      "generate", "The main job: scene -> voxel world -> guidance buffers and frames -> 3D Gaussians, as one package");
  cmd->add_option("scene_file", a->path.scene, "Scene (icube JSON, Waymo TFRecord, OpenDRIVE)")->type_name("SCENE");
  add_camera_path_options(cmd, a->path);
  cmd->add_option("--world", a->world, "Use this voxel world (e.g. from `world build --generator diffusion`) for Stage 1")
      ->type_name("WORLD.icw");
  cmd->add_option("--prompt", a->prompt, "Text prompt of the appearance frames (time of day, weather, season)")
      ->type_name("TEXT")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "Seed of every stage (world detail, instance colours, appearance)")
      ->capture_default_str();
  c->gsm.key_every = cmd->add_option("--key-every", a->key_every,
                                     "Stage 3 lifts every N-th frame; the others are held out (with --gsm default 6)")
                         ->capture_default_str()
                         ->check(CLI::Range(size_t{1}, size_t{1000000}));
  cmd->add_option("--gaussians-per-cell", a->per_cell, "Gaussians per seen 0.1 m face cell (1, or 4: official density)")
      ->capture_default_str()
      ->check(CLI::IsMember({1, 4}));
  cmd->add_option("--frames-from", a->frames_from,
                  "Appearance frames made elsewhere from this job's guidance buffers (a video model's output: a "
                  "PNG folder or an mp4, one frame per buffer frame), imported instead of the procedural renderer's")
      ->type_name("DIR|VIDEO.mp4");
  add_sky_mask_options(cmd, a->sky_masks, a->sky_label, "the --frames-from frames");
  cmd->add_option("--pixel-frames", a->pixel_frames,
                  "Stage 3 pixel branch: Gaussians for the mid-ground pixels of the last N key frames (0 = off)")
      ->capture_default_str();
  add_gsm_options(cmd, c->gsm);
  cmd->add_flag("--no-video", a->no_video, "No mp4s (guidance buffers, the preview's fly-through)");
  cmd->add_option("--video-preset", a->video_preset,
                  "x264 preset of the guidance buffers' mp4s (InfiniCube's: veryslow; ultrafast ... veryslow trades "
                  "time for file size; on 2 cores its x264 time is ~25 % of a 1,000-frame job, medium ~15 %)")
      ->check(CLI::IsMember(video::x264_presets()))
      ->capture_default_str();
  cmd->add_flag("--no-preview", a->no_preview, "No preview/ (the Gaussians rendered along the trajectory)");
  cmd->add_flag("--resume", a->resume,
                "Continue a killed run after its last finished stage; nothing to do when the package is complete");
  cmd->add_option("--batch", c->batch,
                  "Generate every scene listed (one path per line, '#' comments) into OUT_ROOT/<scene stem>/; "
                  "implies --resume")
      ->type_name("SCENES.txt");
  cmd->add_option("--shard", c->shard, "With --batch: do every N-th scene starting at I (0-based)")
      ->type_name("I/N")
      ->capture_default_str();
  cmd->add_option("-o,--output", a->output, "Package folder (with --batch: the folder of the packages)")
      ->type_name("PACKAGE");
  cmd->footer(
      "Stage 1 with the procedural world prior (or --world), Stage 2 with the built-in appearance renderer, Stage 3 "
      "with the non-learned lifting of docs/stage3-lifting.md, or with --gsm the learned model (InfiniCube's GSM). The package is written atomically; see docs/generate.md "
      "(also for running shards as a Slurm job array or a Kubernetes Indexed Job).");
  cmd->callback([c] { cmd_generate(*c); });
}

const CommandRegistrar kGenerateRegistrar(add_generate_command, 5);

}  // namespace

}  // namespace icube::tools
