// `icube world build` (Stage 1: a semantic voxel world from a scene, chunk by
// chunk, engine/world/world_build.h) and `icube world plot` (a top-down PNG
// of a world, engine/world/world_plot.h).
//
//   icube world build SCENE -o world.icw [--mode trajectory|blocks] [--generator procedural]
//                     [--seed N] [--record SEL] [--extrapolate N] [--threads N] [--no-vehicles]
//                     [--vehicle-mesh FILE [--mesh-axes F,U] | --vehicle-meshes JSON] [--png top.png]
//   icube world plot WORLD -o top.png [--max-pixels N]
#include "cli_common.h"
#include "command_registry.h"
#include "mesh_args.h"
#include "progress.h"
#include "world_top_png.h"

#include "scene/scene_load.h"
#include "world/procedural/procedural_prior.h"
#include "world/semantics.h"
#include "world/vehicle_mesh_set.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <sys/resource.h>

#include <cstdio>
#include <memory>
#include <string>

namespace icube::tools {

namespace {

struct BuildArgs {
  std::string file, output, record, png, vehicle_mesh, vehicle_meshes, mesh_axes = "auto";
  std::string mode = "trajectory";
  std::string generator = "procedural";
  uint64_t seed = 0;
  int threads = 0;
  bool no_vehicles = false;
  world::PlanOptions plan;
};

double peak_rss_mib() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_maxrss) / 1024.0;  // Linux: KiB
}

void print_summary(const world::WorldBuildResult& r, const world::WorldGenerator& gen,
                   const world::VehicleMeshSet& meshes) {
  const world::VoxelGrid& g = r.world;
  const double voxels = static_cast<double>(g.voxel_count());
  std::printf("built %s world (%s generator): %zu chunk(s), %llu voxels in %zu bricks, %.1f MiB\n",
              world::plan_mode_name(r.plan.mode), gen.name().c_str(), r.plan.chunks.size(),
              static_cast<unsigned long long>(g.voxel_count()), g.brick_count(),
              static_cast<double>(g.memory_bytes()) / (1024.0 * 1024.0));
  std::printf("  time %.2f s (plan %.2f, generate %.2f cpu-s, fuse %.2f, vehicles %.2f): %.1f chunks/s, %.2f Mvoxels/s; "
              "peak RSS %.0f MiB\n",
              r.total_s, r.plan_s, r.generate_s, r.fuse_s, r.vehicles_s,
              r.total_s > 0 ? static_cast<double>(r.plan.chunks.size()) / r.total_s : 0.0,
              r.total_s > 0 ? voxels / r.total_s * 1e-6 : 0.0, peak_rss_mib());
  std::printf("  %zu static vehicle(s) inserted, %llu voxels", r.vehicles_inserted,
              static_cast<unsigned long long>(r.vehicle_voxels));
  for (size_t i = 0; i < r.vehicles_per_type.size() && i < meshes.types.size(); ++i)
    std::printf("%s %zu %s (%s)", i ? "," : ":", r.vehicles_per_type[i], meshes.types[i].name.c_str(),
                meshes.types[i].source.c_str());
  std::printf("\n");
  const auto hist = g.class_histogram();
  std::printf("  classes:");
  int shown = 0;
  for (int c = 1; c < world::kNumSemanticClasses; ++c) {
    const uint64_t n = hist[static_cast<size_t>(c)];
    if (!n) continue;
    std::printf("%s %s %.2f%%", shown++ % 6 == 0 ? "\n   " : ",", world::semantic_class_name(static_cast<uint8_t>(c)),
                voxels > 0 ? 100.0 * static_cast<double>(n) / voxels : 0.0);
  }
  std::printf("\n");
}

// --vehicle-mesh, --vehicle-meshes or the built-in car; read before any chunk is built.
world::VehicleMeshSet vehicle_meshes(const BuildArgs& a) {
  const auto axes = mesh_axes_arg(a.mesh_axes);
  if (!a.vehicle_meshes.empty()) return world::load_vehicle_mesh_set(a.vehicle_meshes);
  if (a.vehicle_mesh.empty()) return world::builtin_vehicle_meshes();
  world::VehicleMeshFile f = world::load_vehicle_mesh(a.vehicle_mesh, axes);
  const std::string source = describe_mesh(a.vehicle_mesh, f);
  return world::single_vehicle_mesh(std::move(f), source);
}

void cmd_build(BuildArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(a.file, a.output);
    if (!a.png.empty()) refuse_overwriting_input(a.file, a.png);
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    const scene::Scene s = scene::load_scene(a.file, lo, &diag);
    const world::VehicleMeshSet meshes = vehicle_meshes(a);
    const auto generator = std::make_unique<world::ProceduralPrior>(s);

    world::WorldBuildOptions opts;
    opts.mode = a.mode == "blocks" ? world::PlanMode::Blocks : world::PlanMode::Trajectory;
    opts.plan = a.plan;
    opts.seed = a.seed;
    opts.threads = a.threads;
    opts.insert_static_vehicles = !a.no_vehicles;
    opts.vehicle_meshes = &meshes;
    ProgressBar bar("world build", "chunks");
    opts.progress = [&](size_t done, size_t total) { bar.update(done, total); };
    const world::WorldBuildResult r = world::build_world(s, *generator, opts);
    for (const std::string& note : r.plan.notes) diag.warn(a.file, "plan", note);
    world::save_world(r.world, a.output);
    print_summary(r, *generator, meshes);
    std::printf("wrote %s\n", a.output.c_str());
    if (!a.png.empty()) write_top_png(r.world, a.png);
  });
}

void cmd_plot(const std::string& input, const std::string& output, int max_pixels) {
  run_command([&](scene::Diagnostics&) {
    refuse_overwriting_input(input, output);
    const world::VoxelGrid g = world::load_world(input);
    write_top_png(g, output, max_pixels);
  });
}

void add_world_build_commands(CLI::App& app) {
  CLI::App& world_cmd = subcommand_group(app, "world", "Build, inspect, import and export semantic voxel worlds");

  auto a = std::make_shared<BuildArgs>();
  CLI::App* build = world_cmd.add_subcommand(
      "build", "Stage 1: generate a semantic voxel world (0.2 m, 23 classes) for a scene, chunk by chunk, and save it");
  build->add_option("file", a->file, "Scene file: icube scene JSON, Waymo Scenario TFRecord, or OpenDRIVE .xodr")
      ->required()
      ->type_name("SCENE");
  build->add_option("-o,--output", a->output, "Output world file")->required()->type_name("world.icw");
  build->add_option("--record", a->record, "Waymo TFRecord only: which record, by index or scenario id")
      ->type_name("SEL");
  build->add_option("--mode", a->mode, "trajectory: chunks along the ego drive; blocks: world-axis lattice over the road")
      ->check(CLI::IsMember({"trajectory", "blocks"}))
      ->type_name("MODE")
      ->capture_default_str();
  build->add_option("--generator", a->generator,
                    "procedural: the built-in procedural world prior (rules on the map, not a learned model)")
      ->check(CLI::IsMember({"procedural"}))
      ->type_name("NAME")
      ->capture_default_str();
  build->add_option("--seed", a->seed, "Generator seed (same seed, same scene: identical world file)")
      ->type_name("N")
      ->capture_default_str();
  build->add_option("--extrapolate", a->plan.extrapolate_chunks,
                    "Trajectory mode: chunks to continue straight past the end of the drive")
      ->type_name("N")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  build->add_option("--threads", a->threads, "Generator threads (0: one per core); the result does not depend on it")
      ->type_name("N")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  build->add_flag("--no-vehicles", a->no_vehicles, "Do not insert the static vehicles of the first frame");
  CLI::Option* mesh_opt =
      build->add_option("--vehicle-mesh", a->vehicle_mesh,
                        "Voxelise every static vehicle from this mesh (PLY, OBJ, glTF/GLB) instead of the built-in car")
          ->type_name("FILE");
  build->add_option("--vehicle-meshes", a->vehicle_meshes,
                    "Per-type meshes picked by box length, e.g. {\"car\": {\"mesh\": \"car.ply\", \"length\": [0, 6.5]}, "
                    "\"truck\": {\"mesh\": \"truck.glb\", \"length\": [6.5, 10]}} (docs/vehicle-meshes.md)")
      ->type_name("JSON")
      ->excludes(mesh_opt);
  build->add_option("--mesh-axes", a->mesh_axes, std::string(kMeshAxesHelp) + " (for --vehicle-mesh)")
      ->type_name("FORWARD,UP")
      ->needs(mesh_opt)
      ->capture_default_str();
  build->add_option("--png", a->png, "Also write a top-down picture of the world")->type_name("top.png");
  build->footer(
      "Chunks are fused in plan order with existing voxels winning. Static vehicles (the boxes of frame 0 that "
      "never move) are voxelised into the chunks they stand in from the built-in car mesh, --vehicle-mesh or the "
      "type --vehicle-meshes picks by box length (whose name is also the voxels' class).");
  build->callback([a] { cmd_build(*a); });

  auto in = std::make_shared<std::string>(), out = std::make_shared<std::string>();
  auto max_px = std::make_shared<int>(4096);
  CLI::App* plot = world_cmd.add_subcommand(
      "plot", "Write a top-down PNG of a world: each column's highest voxel, coloured by class, shaded by height");
  plot->add_option("world", *in, "World file (.icw)")->required()->type_name("WORLD");
  plot->add_option("-o,--output", *out, "Output PNG")->required()->type_name("top.png");
  plot->add_option("--max-pixels", *max_px, "Longest side of the picture; larger worlds are drawn coarser")
      ->check(CLI::Range(64, 16384))
      ->capture_default_str();
  plot->callback([in, out, max_px] { cmd_plot(*in, *out, *max_px); });
}

const CommandRegistrar kRegistrar(add_world_build_commands, 32);

}  // namespace

}  // namespace icube::tools
