// `icube world plan` (which Stage-1 chunks a scene needs, engine/world/chunk_plan.h)
// and `icube world demo-scene` (the embedded synthetic town, engine/world/demo_scene.h).
//
//   icube world plan SCENE [--mode trajectory|blocks] [-o plan.png] [--json plan.json] [--record SEL]
//                    [--extrapolate N] [--width PX]
//   icube world demo-scene -o scene.json
//
// Errors print one line, "icube: error: ...", and exit with status 1.
#include "cli_common.h"
#include "command_registry.h"

#include "scene/atomic_file.h"
#include "scene/scene_json.h"
#include "scene/scene_load.h"
#include "world/chunk_plan.h"
#include "world/chunk_plan_plot.h"
#include "world/demo_scene.h"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>

namespace icube::tools {

namespace {

struct PlanArgs {
  std::string file, record, png, json;
  std::string mode = "trajectory";
  world::PlanOptions plan;
  world::PlanPlotOptions plot;
};


void print_table(const world::ChunkPlan& plan) {
  std::printf("%s plan: %zu chunk(s), stride %.1f m", world::plan_mode_name(plan.mode), plan.chunks.size(),
              plan.stride_m);
  if (plan.mode == world::PlanMode::Trajectory) std::printf(", ego travel %.1f m", plan.path_length_m);
  std::printf("\n%5s  %14s %14s %10s  %12s  %s\n", "index", "centre x", "centre y", "centre z", "heading(deg)", "kind");
  for (size_t n = 0; n < plan.chunks.size(); ++n) {
    const glm::dvec3 c = world::chunk_centre(plan.chunks[n]);
    const double deg = world::chunk_heading(plan.chunks[n]) * 180.0 / std::numbers::pi;
    std::printf("%5d  %14.3f %14.3f %10.3f  %12.1f  %s\n", plan.chunks[n].index, c.x, c.y, c.z, deg,
                world::chunk_kind_name(plan.info[n].kind));
  }
}

void cmd_plan(PlanArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    if (!a.png.empty()) refuse_overwriting_input(a.file, a.png);
    if (!a.json.empty()) refuse_overwriting_input(a.file, a.json);
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    const scene::Scene s = scene::load_scene(a.file, lo, &diag);
    const world::PlanMode mode = a.mode == "blocks" ? world::PlanMode::Blocks : world::PlanMode::Trajectory;
    const world::ChunkPlan plan = world::plan_chunks(s, mode, a.plan);
    for (const std::string& note : plan.notes) diag.warn(a.file, "plan", note);
    print_table(plan);
    if (!a.json.empty()) {
      scene::write_file_atomic(a.json, world::plan_to_json(plan));
      std::printf("wrote %s\n", a.json.c_str());
    }
    if (!a.png.empty()) {
      const scene::MapPlot p = world::render_plan(s, plan, a.plot);
      scene::write_map_png(p, a.png);
      std::printf("wrote %s (%d x %d px, %.3g m/px)\n", a.png.c_str(), p.image.width(), p.image.height(),
                  1.0 / p.view.pixels_per_metre);
    }
  });
}

void cmd_demo_scene(const std::string& output) {
  run_command([&](scene::Diagnostics&) {
    const scene::Scene s = world::make_demo_scene();
    const std::string text = scene::scene_to_json(s);
    scene::write_file_atomic(output, text);
    std::printf("wrote %s (%zu bytes): demo town, %zu lanes, %zu tracks, %zu timestamps at 10 Hz\n", output.c_str(),
                text.size(), s.map.lanes.size(), s.tracks.size(), s.timestamps.size());
  });
}

void add_world_plan_commands(CLI::App& app) {
  CLI::App& world_cmd = tools::subcommand_group(app, "world", "Build, inspect, import and export semantic voxel worlds");

  auto pa = std::make_shared<PlanArgs>();
  CLI::App* plan = world_cmd.add_subcommand(
      "plan", "Plan the Stage-1 chunks of a scene (51.2 m cubes every 38.4 m along the ego drive, or a lattice "
              "over the road) and print them as a table; optionally plot them and write them as JSON");
  plan->add_option("file", pa->file, "Scene file: icube scene JSON, Waymo Scenario TFRecord, or OpenDRIVE .xodr")
      ->required()
      ->type_name("FILE");
  plan->add_option("--record", pa->record, "Waymo TFRecord only: which record, by index or scenario id")
      ->type_name("SEL");
  plan->add_option("--mode", pa->mode, "trajectory: keys along the ego drive; blocks: world-axis lattice over the road")
      ->check(CLI::IsMember({"trajectory", "blocks"}))
      ->type_name("MODE")
      ->capture_default_str();
  plan->add_option("-o,--output", pa->png, "Plot the plan over the map to this PNG")->type_name("plan.png");
  plan->add_option("--json", pa->json, "Write the plan as JSON (chunk_to_world per chunk)")->type_name("plan.json");
  plan->add_option("--extrapolate", pa->plan.extrapolate_chunks,
                   "Trajectory mode: chunks to continue straight past the end of the drive")
      ->type_name("N")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  plan->add_option("--width", pa->plot.width, "Plot width in pixels")
      ->type_name("PX")
      ->check(CLI::Range(320, 16384))
      ->capture_default_str();
  plan->footer(
      "Trajectory mode needs an ego drive with at least 2 valid poses (OpenDRIVE maps: make one with `icube scene "
      "route`); a parked ego gives one chunk. Blocks mode keeps blocks holding road-edge points and road-surface points "
      "(the fitted road surface of the lanes between the road edges, 0.4 m cells).");
  plan->callback([pa] { cmd_plan(*pa); });

  auto out = std::make_shared<std::string>();
  CLI::App* demo = world_cmd.add_subcommand(
      "demo-scene", "Write the built-in demo scene (a synthetic suburban 4-way junction with parked and moving "
                    "cars, pedestrians and a 10 Hz ego drive through the junction) as icube scene JSON");
  demo->add_option("-o,--output", *out, "Output path of the scene JSON")->required()->type_name("scene.json");
  demo->callback([out] { cmd_demo_scene(*out); });
}

const CommandRegistrar kWorldPlanRegistrar(add_world_plan_commands, 35);

}  // namespace

}  // namespace icube::tools
