// `icube world insert`: one object from a user's mesh (PLY, OBJ, glTF/GLB)
// fitted into an oriented box and voxelised into an existing world
// (engine/world/object_insert.h).
//
//   icube world insert WORLD --mesh FILE --box cx,cy,cz,l,w,h,heading -o OUT
//                      [--class car] [--instance N] [--overwrite] [--mesh-axes F,U] [--png top.png]
#include "cli_common.h"
#include "command_registry.h"
#include "mesh_args.h"
#include "world_top_png.h"

#include "world/object_insert.h"
#include "world/semantics.h"
#include "world/vehicle_mesh.h"
#include "world/voxel_grid.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>

namespace icube::tools {

namespace {

struct InsertArgs {
  std::string world, mesh, box, output, png, axes = "auto";
  std::string class_name = "car";
  uint32_t instance = 0;
  bool overwrite = false;
};

uint8_t class_arg(const std::string& name) {
  const auto c = world::semantic_class_from_name(name);
  if (c) return *c;
  std::string known;
  for (int k = 1; k < world::kNumSemanticClasses; ++k)
    known += std::string(k > 1 ? ", " : "") + world::semantic_class_name(static_cast<uint8_t>(k));
  throw std::invalid_argument("--class '" + scene::printable(name) + "': unknown class (" + known + ")");
}

void cmd_insert(const InsertArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(a.world, a.output);
    refuse_overwriting_input(a.mesh, a.output);
    if (!a.png.empty()) refuse_overwriting_input(a.world, a.png);
    scene::BoxState box;
    try {
      box = world::parse_box_spec(a.box);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("--box ") + e.what());
    }
    world::ObjectInsertOptions o;
    o.class_id = class_arg(a.class_name);
    o.instance_id = a.instance;
    o.overwrite = a.overwrite;
    const auto axes = mesh_axes_arg(a.axes);
    world::VoxelGrid g = world::load_world(a.world);
    const world::VehicleMeshFile mesh = world::load_vehicle_mesh(a.mesh, axes);
    const uint64_t before = g.voxel_count();
    if (o.instance_id) {
      uint64_t used = 0;
      g.for_each_voxel([&](const glm::ivec3&, const world::Voxel& v) { used += v.instance == o.instance_id; });
      if (used)
        diag.warn(
            a.world, "",
            "instance " + std::to_string(o.instance_id) + " is already used by " + std::to_string(used) + " voxel(s)");
    }
    const world::ObjectInsertResult r = world::insert_object(g, mesh.mesh, box, o);
    if (r.written == 0) diag.warn(a.mesh, "", "the object wrote no voxel (all its cells were taken or out of range)");
    if (r.out_of_range)
      diag.warn(a.mesh, "", std::to_string(r.out_of_range) + " cell(s) beyond the grid's range dropped");
    world::save_world(g, a.output);
    std::printf("inserted %s, instance %u, from %s\n", world::semantic_class_name(o.class_id), r.instance_id,
                describe_mesh(a.mesh, mesh).c_str());
    std::printf("  box centre %.3f, %.3f, %.3f m; %.3f x %.3f x %.3f m; heading %.2f deg\n", box.center.x, box.center.y,
                box.center.z, box.length, box.width, box.height, box.heading * 180.0 / std::numbers::pi);
    std::printf("  %zu cells: %llu written (%llu replaced), %llu kept existing voxels%s\n", r.cells,
                static_cast<unsigned long long>(r.written), static_cast<unsigned long long>(r.replaced),
                static_cast<unsigned long long>(r.kept_existing),
                r.kept_existing && !o.overwrite ? " (--overwrite replaces them)" : "");
    std::printf("  world %llu -> %llu voxels\n", static_cast<unsigned long long>(before),
                static_cast<unsigned long long>(g.voxel_count()));
    std::printf("wrote %s\n", a.output.c_str());
    if (!a.png.empty()) write_top_png(g, a.png);
  });
}

void add_world_insert_command(CLI::App& app) {
  CLI::App& world_cmd = subcommand_group(app, "world", "Build, inspect, import and export semantic voxel worlds");
  auto a = std::make_shared<InsertArgs>();
  CLI::App* ins = world_cmd.add_subcommand(
      "insert", "Voxelise one object from a mesh (PLY, OBJ, glTF/GLB) fitted into a box and add it to a world");
  ins->add_option("world", a->world, "World file (.icw)")->required()->type_name("WORLD");
  ins->add_option("--mesh", a->mesh,
                  "Object mesh: PLY, OBJ, glTF or GLB (every mesh of the default scene, node "
                  "transforms applied)")
      ->required()
      ->type_name("FILE");
  ins->add_option("--box", a->box,
                  "Box: centre x,y,z (m, world frame, z up; z is the box centre), length, width, height (m) and "
                  "heading (yaw of the length axis from +x, counter-clockwise; radians, or degrees as 90deg)")
      ->required()
      ->type_name("cx,cy,cz,l,w,h,heading");
  ins->add_option("-o,--output", a->output, "Output world file (written atomically)")->required()->type_name("OUT.icw");
  ins->add_option("--class", a->class_name, "Semantic class of the voxels (car, truck, bus, other_vehicle, sign, ...)")
      ->type_name("NAME")
      ->capture_default_str();
  ins->add_option("--instance", a->instance, "Instance id (1-65535); default: one more than the largest in the world")
      ->check(CLI::Range(1u, 65535u))
      ->type_name("N");
  ins->add_flag("--overwrite", a->overwrite,
                "The object's voxels replace voxels already in the world (default: those win)");
  ins->add_option("--mesh-axes", a->axes, kMeshAxesHelp)->type_name("FORWARD,UP")->capture_default_str();
  ins->add_option("--png", a->png, "Also write a top-down picture of the result")->type_name("top.png");
  ins->footer(
      "The mesh's bounding box is scaled per axis to the box (forward = length, left = width, up = height, bottom on "
      "the box bottom), voxelised at 0.1 m (surface + flood-filled interior) and voted into the world's 0.2 m cells.");
  ins->callback([a] { cmd_insert(*a); });
}

const CommandRegistrar kWorldInsertRegistrar(add_world_insert_command, 33);

}  // namespace

}  // namespace icube::tools
