// `icube world info | import | export`: inspect .icw worlds, build them from
// labelled point clouds, export them as PLY points or a GLB mesh.
#include "cli_common.h"
#include "command_registry.h"

#include "world/point_import.h"
#include "world/semantics.h"
#include "world/voxel_grid.h"
#include "world/world_export.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

namespace icube::tools {

namespace {

struct WorldIoArgs {
  std::string input;
  std::string output;
  std::string origin;
};

glm::dvec3 parse_origin(const std::string& s) {
  glm::dvec3 o(0.0);
  if (s.empty()) return o;
  std::istringstream in(s);
  char c1 = 0, c2 = 0;
  std::string rest;
  if (!(in >> o.x >> c1 >> o.y >> c2 >> o.z) || c1 != ',' || c2 != ',' || (in >> rest))
    throw std::runtime_error("--origin '" + s + "': expected X,Y,Z in metres");
  return o;
}

void cmd_info(const WorldIoArgs& a) {
  run_command([&](scene::Diagnostics&) {
    const world::VoxelGrid g = world::load_world(a.input);
    const double vs = g.voxel_size();
    std::printf("world %s\n", a.input.c_str());
    std::printf("  voxels      %llu\n", static_cast<unsigned long long>(g.voxel_count()));
    std::printf("  bricks      %zu (8^3), %.1f%% full\n", g.brick_count(),
                g.brick_count() ? 100.0 * static_cast<double>(g.voxel_count()) /
                                      (512.0 * static_cast<double>(g.brick_count()))
                                : 0.0);
    std::printf("  memory      %.2f MiB in RAM\n", static_cast<double>(g.memory_bytes()) / (1024.0 * 1024.0));
    std::printf("  voxel size  %.9g m\n", vs);
    std::printf("  origin      %.17g, %.17g, %.17g m\n", g.origin().x, g.origin().y, g.origin().z);
    const world::IjkBounds b = g.bounds();
    if (b.empty()) {
      std::printf("  bounds      (empty)\n");
    } else {
      const glm::dvec3 lo = g.origin() + glm::dvec3(b.min) * vs, hi = g.origin() + glm::dvec3(b.max + 1) * vs;
      std::printf("  ijk bounds  [%d, %d] x [%d, %d] x [%d, %d]\n", b.min.x, b.max.x, b.min.y, b.max.y, b.min.z,
                  b.max.z);
      std::printf("  bounds      x [%.3f, %.3f]  y [%.3f, %.3f]  z [%.3f, %.3f] m\n", lo.x, hi.x, lo.y, hi.y, lo.z,
                  hi.z);
      std::printf("  extent      %.3f x %.3f x %.3f m\n", hi.x - lo.x, hi.y - lo.y, hi.z - lo.z);
    }
    const auto hist = g.class_histogram();
    std::printf("  classes\n");
    for (int c = 1; c < world::kNumSemanticClasses; ++c) {
      const uint64_t n = hist[static_cast<size_t>(c)];
      if (!n) continue;
      std::printf("    %2d %-18s %12llu  %6.2f%%\n", c, world::semantic_class_name(static_cast<uint8_t>(c)),
                  static_cast<unsigned long long>(n),
                  100.0 * static_cast<double>(n) / static_cast<double>(g.voxel_count()));
    }
  });
}

void cmd_import(const WorldIoArgs& a) {
  run_command([&](scene::Diagnostics&) {
    const glm::dvec3 origin = parse_origin(a.origin);
    world::ImportStats st;
    const world::VoxelGrid g = world::import_points(a.input, origin, world::kFineVoxel, &st);
    world::save_world(g, a.output);
    std::printf("wrote %s: %llu voxels in %zu bricks from %llu points (%llu labelled) of %s\n", a.output.c_str(),
                static_cast<unsigned long long>(g.voxel_count()), g.brick_count(),
                static_cast<unsigned long long>(st.points), static_cast<unsigned long long>(st.labelled_points),
                a.input.c_str());
  });
}

void cmd_export(const WorldIoArgs& a) {
  run_command([&](scene::Diagnostics&) {
    const world::VoxelGrid g = world::load_world(a.input);
    const world::ExportStats st = world::export_world(g, a.output);
    if (st.points)
      std::printf("wrote %s: %llu points, %zu bytes\n", a.output.c_str(), static_cast<unsigned long long>(st.points),
                  st.bytes);
    else
      std::printf("wrote %s: %llu quads (%llu triangles) in %llu class primitives, %zu bytes\n", a.output.c_str(),
                  static_cast<unsigned long long>(st.quads), static_cast<unsigned long long>(st.triangles),
                  static_cast<unsigned long long>(st.primitives), st.bytes);
  });
}

void add_world_io_commands(CLI::App& app) {
  CLI::App& world_cmd = subcommand_group(app, "world", "Build, inspect, import and export semantic voxel worlds");

  auto info_args = std::make_shared<WorldIoArgs>();
  CLI::App* info = world_cmd.add_subcommand(
      "info", "Print a world's voxel and brick counts, memory, origin, bounds in metres and class histogram");
  info->add_option("world", info_args->input, "World file (.icw)")->required()->type_name("WORLD");
  info->callback([info_args] { cmd_info(*info_args); });

  auto imp_args = std::make_shared<WorldIoArgs>();
  CLI::App* imp = world_cmd.add_subcommand(
      "import", "Voxelise a labelled point cloud at 0.2 m by per-voxel majority vote into a world file");
  imp->add_option("points", imp_args->input,
                  "Points: .npy (N,4|5) float32/64 x,y,z,class[,instance], or .ply with x,y,z and "
                  "class|label|semantic[, instance]")
      ->required()
      ->type_name("POINTS");
  imp->add_option("-o,--output", imp_args->output, "Output world file")->required()->type_name("world.icw");
  imp->add_option("--origin", imp_args->origin,
                  "Grid origin in metres (corner of voxel 0,0,0; default 0,0,0); voxels must lie within "
                  "+-2^23 voxels of it")
      ->type_name("X,Y,Z");
  imp->callback([imp_args] { cmd_import(*imp_args); });

  auto exp_args = std::make_shared<WorldIoArgs>();
  CLI::App* exp = world_cmd.add_subcommand(
      "export", "Export a world as a coloured PLY point cloud (voxel centres) or a GLB mesh of greedily merged faces");
  exp->add_option("world", exp_args->input, "World file (.icw)")->required()->type_name("WORLD");
  exp->add_option("-o,--output", exp_args->output, "Output: .ply (points) or .glb (mesh)")
      ->required()
      ->type_name("OUT.ply|OUT.glb");
  exp->callback([exp_args] { cmd_export(*exp_args); });
}

const CommandRegistrar kWorldIoRegistrar(add_world_io_commands, 30);

}  // namespace

}  // namespace icube::tools
