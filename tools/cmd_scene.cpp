// `icube scene info` and `icube scene convert` (see cmd_scene.h); `plot` and
// `route` are added by add_scene_plot_commands() from cmd_scene_plot.cpp.
#include "cmd_scene.h"

#include "cli_common.h"

#include "cmd_scene_plot.h"
#include "scene/atomic_file.h"
#include "scene/scene_json.h"
#include "scene/scene_load.h"
#include "scene/scene_summary.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>

namespace icube::tools {

namespace {

struct SceneArgs {
  std::string file;
  std::string record;
  std::string output;
  double step = scene::OpenDriveOptions{}.sample_step;
  bool step_given = false;
};


scene::LoadOptions load_options(const SceneArgs& a, scene::Diagnostics& diag) {
  scene::LoadOptions o;
  o.waymo_selector = a.record;
  o.opendrive.sample_step = a.step;
  if (a.step_given && scene::detect_scene_format(a.file) != scene::SceneFormat::OpenDrive)
    diag.warn(a.file, "", "--step applies to OpenDRIVE maps only; ignored");
  return o;
}

void cmd_info(const SceneArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    const scene::Scene s = scene::load_scene(a.file, load_options(a, diag), &diag);
    std::fputs(scene::format_summary(scene::summarize(s)).c_str(), stdout);
  });
}

void cmd_convert(const SceneArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(a.file, a.output);
    const scene::Scene s = scene::load_scene(a.file, load_options(a, diag), &diag);
    const std::string text = scene::scene_to_json(s);
    scene::write_file_atomic(a.output, text);
    const scene::SceneSummary sum = scene::summarize(s);
    const size_t features = sum.road_edges + sum.road_lines + sum.lanes + sum.crosswalks + sum.driveways +
                            sum.speed_bumps + sum.stop_signs;
    std::printf("wrote %s (%zu bytes, icube scene JSON version %d): %zu map features with %zu points, %zu tracks, "
                "%zu timestamps, %zu ego poses, %zu cameras, from %s (%s)\n",
                a.output.c_str(), text.size(), scene::kSceneJsonVersion, features, sum.map_points, sum.tracks,
                sum.timestamps, sum.ego_poses, sum.camera_names.size(), a.file.c_str(),
                s.provenance.source_format.empty() ? "unknown format" : s.provenance.source_format.c_str());
  });
}

void add_common_options(CLI::App& cmd, SceneArgs& a) {
  cmd.add_option("file", a.file, "Scene file: icube scene JSON, Waymo Scenario TFRecord, or OpenDRIVE .xodr")
      ->required()
      ->type_name("FILE");
  cmd.add_option("--record", a.record,
                 "Waymo TFRecord only: which record, by index (0 = first) or scenario id (default: the first)")
      ->type_name("SEL");
}

}  // namespace

void add_scene_commands(CLI::App& app) {
  CLI::App* scene_cmd = app.add_subcommand(
      "scene", "Read, inspect and convert driving scenes (icube JSON, Waymo Scenario TFRecord, OpenDRIVE)");
  scene_cmd->require_subcommand(1);
  scene_cmd->footer(
      "Formats are recognised by content: icube scene JSON (docs/scene-format.md), Waymo Open Motion Dataset "
      "Scenario TFRecords, OpenDRIVE 1.4-1.8 maps.");

  auto info_args = std::make_shared<SceneArgs>();
  CLI::App* info = scene_cmd->add_subcommand(
      "info", "Print what a scene holds: map features and tracks by type, map extent, time span, ego path, "
              "cameras, and what the source lacks");
  add_common_options(*info, *info_args);
  info->callback([info_args] { cmd_info(*info_args); });

  auto conv_args = std::make_shared<SceneArgs>();
  CLI::App* convert = scene_cmd->add_subcommand(
      "convert", "Convert any supported scene file to icube scene JSON (lossless, written atomically)");
  add_common_options(*convert, *conv_args);
  convert->add_option("-o,--output", conv_args->output, "Output path of the scene JSON")
      ->required()
      ->type_name("scene.json");
  CLI::Option* step = convert
                          ->add_option("--step", conv_args->step,
                                       "OpenDRIVE only: sampling step along each road in metres")
                          ->type_name("METRES")
                          ->check(CLI::Range(0.01, 100.0))
                          ->capture_default_str();
  convert->callback([conv_args, step] {
    conv_args->step_given = step->count() > 0;
    cmd_convert(*conv_args);
  });

  // `scene plot` and `scene route` live in tools/cmd_scene_plot.cpp.
  add_scene_plot_commands(*scene_cmd);
}

}  // namespace icube::tools
