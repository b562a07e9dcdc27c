// `icube world insert` and `icube world build --vehicle-mesh/--vehicle-meshes`
// end to end (tools/cmd_world_insert.cpp, cmd_world_build.cpp) through the
// `icube` binary next to icube-tests: an object added to a world with a road
// slab (existing voxels win, or --overwrite; --class, --instance, --png), the
// per-type JSON giving the demo scene's longer cars the truck class, and bad
// input (missing files, malformed or NaN boxes, zero and negative sizes, an
// unknown class, bad axes, a bad JSON key): one "icube: error:" line naming
// the problem, a non-zero exit and no output file. Skips with a message when
// the `icube` binary was not built.
#include "world/car_mesh.h"
#include "world/demo_scene.h"
#include "world/mesh_voxelize.h"
#include "world/voxel_grid.h"
#include "world/world_file.h"

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/scene_json.h"

#include <doctest/doctest.h>

#include <string>
#include <tuple>

using namespace icube;
namespace fs = std::filesystem;

namespace {

size_t count_lines(const std::string& s, const std::string& prefix) {
  size_t n = 0, at = 0;
  while ((at = s.find(prefix, at)) != std::string::npos) ++n, at += prefix.size();
  return n;
}

// A 20 x 20 m road slab one voxel thick at z in [0, 0.2).
world::VoxelGrid road_slab() {
  world::VoxelGrid g;
  for (int i = -50; i < 50; ++i)
    for (int j = -50; j < 50; ++j) g.set({i, j, 0}, static_cast<uint8_t>(world::SemanticClass::Road));
  return g;
}

bool have_binary() {
  if (fs::exists(test::icube_binary())) return true;
  MESSAGE("skipped: " << test::icube_binary().string() << " not built (cmake --build ... --target icube)");
  return false;
}

}  // namespace

TEST_CASE("cli: icube world insert adds one object, keeps or overwrites existing voxels, and rejects bad input") {
  if (!have_binary()) return;
  test::TempDir t("cli-world-insert");
  const fs::path world = t.path / "road.icw", mesh = t.path / "car.obj", out = t.path / "out.icw";
  world::save_world(road_slab(), world.string());
  scene::write_file_atomic(mesh.string(), world::mesh_to_obj(world::builtin_car_mesh()));
  const std::string base = "world insert '" + world.string() + "' --mesh '" + mesh.string() + "'";
  const std::string box = " --box 1.1,-0.3,0.75,4.5,1.9,1.5,30deg";
  scene::BoxState b;
  b.center = {1.1, -0.3, 0.75}, b.length = 4.5, b.width = 1.9, b.height = 1.5, b.heading = glm::radians(30.0);
  const auto cells = world::voxelize_vehicle(world::builtin_car_mesh(), b, 1);
  size_t on_road = 0;
  for (const auto& c : cells) on_road += c.ijk.z == 0 && std::abs(c.ijk.x) <= 50 && std::abs(c.ijk.y) <= 50;
  REQUIRE(on_road > 0);

  SUBCASE("--help") {
    const auto r = test::run_icube("world insert --help", t.path);
    CHECK(r.code == 0);
    CHECK(r.output.find("--box") != std::string::npos);
    CHECK(r.output.find("--overwrite") != std::string::npos);
  }

  SUBCASE("existing voxels win; a PNG on request") {
    const fs::path png = t.path / "top.png";
    const auto r = test::run_icube(base + box + " -o '" + out.string() + "' --png '" + png.string() + "'", t.path);
    INFO(r.output);
    REQUIRE(r.code == 0);
    CHECK(r.output.find("inserted car, instance 1, from") != std::string::npos);
    CHECK(r.output.find(std::to_string(on_road) + " kept existing voxels (--overwrite replaces them)") !=
          std::string::npos);
    CHECK(fs::exists(png));
    const world::VoxelGrid g = world::load_world(out.string());
    CHECK(g.voxel_count() == 100 * 100 + cells.size() - on_road);
    CHECK(g.class_histogram()[1] == cells.size() - on_road);
  }

  SUBCASE("--overwrite, --class, --instance") {
    const auto r =
        test::run_icube(base + box + " --overwrite --class truck --instance 77 -o '" + out.string() + "'", t.path);
    INFO(r.output);
    REQUIRE(r.code == 0);
    CHECK(r.output.find("inserted truck, instance 77") != std::string::npos);
    const world::VoxelGrid g = world::load_world(out.string());
    CHECK(g.voxel_count() == 100 * 100 + cells.size() - on_road);
    for (const auto& c : cells) {
      CHECK(g.get(c.ijk).class_id == static_cast<uint8_t>(world::SemanticClass::Truck));
      CHECK(g.get(c.ijk).instance == 77);
    }
  }

  SUBCASE("bad input: one error line, non-zero exit, no output") {
    const std::tuple<std::string, std::string> bad[] = {
        {"world insert '" + (t.path / "nope.icw").string() + "' --mesh '" + mesh.string() + "'" + box, "nope.icw"},
        {"world insert '" + world.string() + "' --mesh '" + (t.path / "nope.glb").string() + "'" + box, "nope.glb"},
        {base + " --box 1,2,3", "--box '1,2,3': expected 7 values"},
        {base + " --box 1,2,3,4,5,6,x", "--box '1,2,3,4,5,6,x': heading 'x' is not a number"},
        {base + " --box 1,nan,3,4,5,6,0", "cy is not finite"},
        {base + " --box 1,2,3,0,5,6,0", "length must be positive"},
        {base + " --box=1,2,3,4,-5,6,0", "width must be positive"},
        {base + box + " --class van", "--class 'van': unknown class (car, truck, bus,"},
        {base + box + " --mesh-axes x,x", "--mesh-axes 'x,x': expected FORWARD,UP"},
    };
    for (const auto& [args, want] : bad) {
      CAPTURE(args);
      const auto r = test::run_icube(args + " -o '" + out.string() + "'", t.path);
      INFO(r.output);
      CHECK(r.code != 0);
      CHECK(count_lines(r.output, "icube: error: ") == 1);
      CHECK(r.output.find(want) != std::string::npos);
      CHECK(!fs::exists(out));
    }
    const auto same = test::run_icube(base + box + " -o '" + world.string() + "'", t.path);
    CHECK(same.code != 0);
    CHECK(same.output.find("is the input file") != std::string::npos);
  }
}

TEST_CASE("cli: icube world build --vehicle-meshes gives each static vehicle its type's mesh and class") {
  if (!have_binary()) return;
  test::TempDir t("cli-world-build-meshes");
  const fs::path scene = t.path / "scene.json", out = t.path / "world.icw", json = t.path / "vehicles.json";
  scene::write_scene_json(world::make_demo_scene(), scene.string());
  fs::create_directories(t.path / "meshes");
  scene::write_file_atomic((t.path / "meshes/car.obj").string(), world::mesh_to_obj(world::builtin_car_mesh()));
  const std::string build = "world build '" + scene.string() + "' -o '" + out.string() + "' --vehicle-meshes '" +
                            json.string() + "' 2>/dev/null";

  SUBCASE("demo cars 4.2-4.9 m long: up to 4.55 m car, longer ones truck") {
    scene::write_file_atomic(json.string(), R"({"car": {"mesh": "meshes/car.obj", "length": [0, 4.55]},
                                               "truck": {"mesh": "meshes/car.obj", "length": [4.55, 12]}})");
    const auto r = test::run_icube(build, t.path);
    INFO(r.output);
    REQUIRE(r.code == 0);
    CHECK(r.output.find(" car (") != std::string::npos);
    CHECK(r.output.find(" truck (") != std::string::npos);
    const auto hist = world::load_world(out.string()).class_histogram();
    CHECK(hist[static_cast<size_t>(world::SemanticClass::Car)] > 0);
    CHECK(hist[static_cast<size_t>(world::SemanticClass::Truck)] > 0);
  }

  SUBCASE("--vehicle-mesh: one mesh for every static vehicle") {
    const std::string obj = (t.path / "meshes/car.obj").string();
    const auto r = test::run_icube("world build '" + scene.string() + "' -o '" + out.string() + "' --vehicle-mesh '" +
                                       obj + "' --mesh-axes +x,+z 2>/dev/null",
                                   t.path);
    INFO(r.output);
    REQUIRE(r.code == 0);
    CHECK(r.output.find(" car (" + obj + " (OBJ, axes +x,+z, ") != std::string::npos);
    const auto hist = world::load_world(out.string()).class_histogram();
    CHECK(hist[static_cast<size_t>(world::SemanticClass::Car)] > 0);
    CHECK(hist[static_cast<size_t>(world::SemanticClass::Truck)] == 0);
  }

  SUBCASE("bad JSON key or mesh: one error line naming the file and key, no world") {
    const std::tuple<std::string, std::string> bad[] = {
        {R"({"car": {"mesh": "meshes/car.obj", "length": [4, 2]}})", "vehicles.json: car.length: must be [min, max]"},
        {R"({"lorry": {"mesh": "meshes/car.obj"}})", "vehicles.json: lorry: unknown vehicle type"},
        {R"({"car": {"mesh": "meshes/nope.ply"}})", "nope.ply: cannot open"},
    };
    for (const auto& [text, want] : bad) {
      CAPTURE(text);
      scene::write_file_atomic(json.string(), text);
      const auto r = test::run_icube(build, t.path);
      INFO(r.output);
      CHECK(r.code != 0);
      CHECK(count_lines(r.output, "icube: error: ") == 1);
      CHECK(r.output.find(want) != std::string::npos);
      CHECK(!fs::exists(out));
    }
    const auto r = test::run_icube("world build '" + scene.string() + "' -o '" + out.string() + "' --vehicle-mesh '" +
                                       (t.path / "none.obj").string() + "'",
                                   t.path);
    CHECK(r.code != 0);
    CHECK(r.output.find("none.obj: cannot open") != std::string::npos);
    CHECK(!fs::exists(out));
  }
}
