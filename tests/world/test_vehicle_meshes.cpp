// User vehicle meshes (engine/world/vehicle_mesh.h, vehicle_mesh_set.h,
// vehicle_insert.h, object_insert.h): FORWARD,UP axes and the rotation into
// the object frame, meshes that cannot fill a box, the per-type JSON (types
// by box length, relative mesh paths, one-line errors naming file and key),
// per-type classes in insert_vehicles, the --box spec and one-object
// insertion (existing voxels win or are overwritten, next instance id).
#include "world/car_mesh.h"
#include "world/mesh_voxelize.h"
#include "world/object_insert.h"
#include "world/vehicle_insert.h"
#include "world/vehicle_mesh.h"
#include "world/vehicle_mesh_set.h"
#include "world/voxel_grid.h"

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <set>
#include <string>
#include <tuple>

using namespace icube::world;
using icube::scene::BoxState;
using icube::scene::InputError;
namespace fs = std::filesystem;

namespace {

BoxState box(glm::dvec3 c, double l, double w, double h, double heading = 0.0) {
  BoxState b;
  b.center = c, b.length = l, b.width = w, b.height = h, b.heading = heading, b.valid = true;
  return b;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

// An axis-aligned box mesh [0, size] (12 triangles).
TriangleMesh block(const glm::dvec3& size) {
  TriangleMesh m;
  for (int k = 0; k < 8; ++k) m.positions.push_back(glm::dvec3(k & 1, (k >> 1) & 1, (k >> 2) & 1) * size);
  const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

}  // namespace

TEST_CASE("vehicle_mesh: FORWARD,UP axes parse, print and rotate without mirroring") {
  const auto gltf = parse_mesh_axes("+z,+y");
  REQUIRE(gltf);
  CHECK(*gltf == default_mesh_axes(MeshFormat::Gltf));
  CHECK(mesh_axes_name(*gltf) == "+z,+y");
  CHECK(*parse_mesh_axes("z,y") == *gltf);
  CHECK(*parse_mesh_axes("+x,+z") == default_mesh_axes(MeshFormat::Ply));
  CHECK(default_mesh_axes(MeshFormat::Obj) == default_mesh_axes(MeshFormat::Ply));
  CHECK(mesh_axes_name(*parse_mesh_axes("-x,-y")) == "-x,-y");
  for (const char* bad : {"", "x", "x,x", "+z,-z", "w,y", "x,y,z", "++x,y", "x, y", "X,Y"}) {
    CAPTURE(bad);
    CHECK(!parse_mesh_axes(bad));
  }
  // glTF: forward +z, up +y, so left is +x: (x, y, z) -> (z, x, y).
  TriangleMesh m;
  m.positions = {{1, 2, 3}};
  orient_mesh(m, *gltf);
  CHECK(m.positions[0] == glm::dvec3(3, 1, 2));
  // Every choice is a rotation: the image of a right-handed frame stays right-handed.
  for (const char* f : {"+x", "-x", "+y", "-y", "+z", "-z"})
    for (const char* u : {"+x", "-x", "+y", "-y", "+z", "-z"}) {
      const auto axes = parse_mesh_axes(std::string(f) + "," + u);
      if (!axes) continue;
      TriangleMesh t;
      t.positions = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
      orient_mesh(t, *axes);
      CHECK(glm::determinant(glm::dmat3(t.positions[0], t.positions[1], t.positions[2])) == doctest::Approx(1.0));
    }
}

TEST_CASE("vehicle_mesh: a glTF-axes OBJ loads with --mesh-axes; empty and flat meshes are one-line errors") {
  icube::test::TempDir dir("vehicle-mesh");
  const std::string obj = (dir.path / "long_y.obj").string();
  icube::scene::write_file_atomic(obj, mesh_to_obj(block({1.8, 1.5, 4.5})));  // x left, y up, z forward
  const VehicleMeshFile f = load_vehicle_mesh(obj, parse_mesh_axes("+z,+y"));
  CHECK(f.format == MeshFormat::Obj);
  const MeshBounds b = mesh_bounds(f.mesh);
  CHECK(b.max - b.min == glm::dvec3(4.5, 1.8, 1.5));
  CHECK(load_vehicle_mesh(obj).axes == default_mesh_axes(MeshFormat::Obj));

  const std::string empty = (dir.path / "empty.obj").string(), flat = (dir.path / "flat.obj").string();
  icube::scene::write_file_atomic(empty, "v 0 0 0\n");
  icube::scene::write_file_atomic(flat, "v 0 0 0\nv 4 0 0\nv 0 2 0\nf 1 2 3\n");
  const std::string e1 = error_of([&] { load_vehicle_mesh(empty); });
  const std::string e2 = error_of([&] { load_vehicle_mesh(flat); });
  CHECK(e1 == empty + ": mesh: no triangles in this OBJ file");
  CHECK(e2.find(flat + ": mesh: no extent along its height (up) axis with axes +x,+z") == 0);
  CHECK(e2.find('\n') == std::string::npos);
}

TEST_CASE("vehicle_mesh_set: the per-type JSON picks a type by box length") {
  icube::test::TempDir dir("vehicle-set");
  fs::create_directories(dir.path / "meshes");
  icube::scene::write_file_atomic((dir.path / "meshes/car.obj").string(), mesh_to_obj(builtin_car_mesh()));
  icube::scene::write_file_atomic((dir.path / "meshes/box.obj").string(), mesh_to_obj(block({1.5, 2.5, 8.0})));
  const std::string json = (dir.path / "vehicles.json").string();
  icube::scene::write_file_atomic(json, R"({
    "bus":   {"mesh": "meshes/box.obj", "length": [10, 30], "axes": "+z,+y"},
    "car":   {"mesh": "meshes/car.obj", "length": [0, 6.5]},
    "truck": {"mesh": ")" + (dir.path / "meshes/box.obj").string() +
                                            R"(", "length": [7, 10]}
  })");
  const VehicleMeshSet s = load_vehicle_mesh_set(json);
  REQUIRE(s.types.size() == 3);
  CHECK(s.types[0].name == "car");  // sorted by length
  CHECK(s.types[1].name == "truck");
  CHECK(s.types[2].name == "bus");
  CHECK(s.types[0].class_id == static_cast<uint8_t>(SemanticClass::Car));
  CHECK(s.types[1].class_id == static_cast<uint8_t>(SemanticClass::Truck));
  CHECK(s.types[2].class_id == static_cast<uint8_t>(SemanticClass::Bus));
  CHECK(s.types[0].source == (dir.path / "meshes/car.obj").string());  // relative to the JSON's folder
  CHECK(s.types[0].mesh.triangles == builtin_car_mesh().triangles);
  const MeshBounds bus = mesh_bounds(s.types[2].mesh);
  CHECK(bus.max - bus.min == glm::dvec3(8.0, 1.5, 2.5));  // "+z,+y" applied
  const std::tuple<double, const char*> picks[] = {{0.5, "car"},    {4.5, "car"},    {6.5, "car"},
                                                   {6.75, "car"},   {6.76, "truck"}, {7, "truck"},
                                                   {9.99, "truck"}, {10, "bus"},     {80, "bus"}};
  for (const auto& [length, name] : picks) {
    CAPTURE(length);
    CHECK(s.pick(length).name == name);  // in a range, else the nearest; the gap's middle goes to the shorter
  }
  const VehicleMeshSet one = builtin_vehicle_meshes();
  REQUIRE(one.types.size() == 1);
  CHECK(one.pick(25.0).name == "car");
  CHECK(one.types[0].source == "built-in car");
}

TEST_CASE("vehicle_mesh_set: bad per-type JSON gives one-line errors naming the file and the key") {
  icube::test::TempDir dir("vehicle-set-bad");
  icube::scene::write_file_atomic((dir.path / "car.obj").string(), mesh_to_obj(builtin_car_mesh()));
  const std::string j = (dir.path / "v.json").string();
  const std::tuple<const char*, const char*> cases[] = {
      {"{\"car\": ", "v.json: not valid JSON: "},
      {"[]", "v.json: expected an object of vehicle types"},
      {"{}", "v.json: expected an object of vehicle types"},
      {R"({"van": {"mesh": "car.obj"}})", "v.json: van: unknown vehicle type (car, truck, bus, other_vehicle)"},
      {R"({"road": {"mesh": "car.obj"}})", "v.json: road: unknown vehicle type"},
      {R"({"c\nar": {"mesh": "car.obj"}})", "v.json: c?ar: unknown vehicle type"},  // a JSON newline in a key
      {R"({"car": "car.obj"})", "v.json: car: must be an object"},
      {R"({"car": {"length": [0, 5]}})", "v.json: car.mesh: missing"},
      {R"({"car": {"mesh": 3}})", "v.json: car.mesh: missing"},
      {R"({"car": {"mesh": "car.obj", "colour": "red"}})", "v.json: car.colour: unknown key (mesh, length, axes)"},
      {R"({"car": {"mesh": "car.obj", "length": [5, 2]}})", "v.json: car.length: must be [min, max]"},
      {R"({"car": {"mesh": "car.obj", "length": [-1, 2]}})", "v.json: car.length: must be [min, max]"},
      {R"({"car": {"mesh": "car.obj", "length": [1, 1e999]}})", "v.json: not valid JSON"},
      {R"({"car": {"mesh": "car.obj", "length": "short"}})", "v.json: car.length: must be [min, max]"},
      {R"({"car": {"mesh": "car.obj", "axes": "x,x"}})", "v.json: car.axes: must be \"FORWARD,UP\""},
      {R"({"car": {"mesh": "car.obj", "length": [0, 5]}, "bus": {"mesh": "car.obj"}})", "v.json: bus.length: missing"},
      {R"({"car": {"mesh": "car.obj", "length": [0, 5]}, "bus": {"mesh": "car.obj", "length": [4, 9]}})",
       "v.json: bus.length: [4, 9) overlaps car's [0, 5)"},
      {R"({"car": {"mesh": "nope.ply"}})", "nope.ply: cannot open"},
  };
  for (const auto& [text, want] : cases) {
    CAPTURE(text);
    icube::scene::write_file_atomic(j, text);
    const std::string msg = error_of([&] { load_vehicle_mesh_set(j); });
    INFO(msg);
    CHECK(msg.find(want) != std::string::npos);
    CHECK(msg.find('\n') == std::string::npos);
  }
  CHECK_THROWS_AS(load_vehicle_mesh_set((dir.path / "missing.json").string()), InputError);
  // The JSON is checked whole before any mesh is read: parsing reads no file, and
  // an overlap is reported although the first mesh is missing.
  const VehicleMeshSet unread = parse_vehicle_mesh_set(R"({"car": {"mesh": "nope.ply"}})", "v.json", "/some/dir");
  CHECK(unread.types.at(0).source == "/some/dir/nope.ply");
  CHECK(unread.types.at(0).mesh.positions.empty());
  icube::scene::write_file_atomic(
      j, R"({"car": {"mesh": "nope.ply", "length": [0, 5]}, "bus": {"mesh": "car.obj", "length": [4, 9]}})");
  CHECK(error_of([&] { load_vehicle_mesh_set(j); }).find("bus.length: [4, 9) overlaps") != std::string::npos);
}

TEST_CASE("vehicle_insert: each static vehicle gets the mesh and class its length picks") {
  icube::scene::Scene s;
  s.timestamps = {0.0};
  auto track = [](int64_t id, uint32_t inst, const BoxState& b) {
    icube::scene::Track t;
    t.id = id, t.type = icube::scene::ObjectType::Vehicle, t.instance_id = inst, t.states = {b};
    return t;
  };
  const BoxState car = box({0, 0, 0.8}, 4.5, 1.9, 1.6), truck = box({20, 0, 1.5}, 8.0, 2.5, 3.0, 0.3),
                 bus = box({0, 20, 1.6}, 12.0, 2.6, 3.2, 1.2);
  s.tracks = {track(1, 3, bus), track(2, 1, car), track(3, 2, truck)};
  VehicleMeshSet set;
  for (const auto& [name, cls, lo, hi] :
       {std::tuple{"car", SemanticClass::Car, 0.0, 6.0}, std::tuple{"truck", SemanticClass::Truck, 6.0, 10.0},
        std::tuple{"bus", SemanticClass::Bus, 10.0, 30.0}}) {
    VehicleType t;
    t.name = name, t.class_id = static_cast<uint8_t>(cls), t.min_length = lo, t.max_length = hi;
    t.mesh = std::string(name) == "car" ? builtin_car_mesh() : block({1, 1, 1});
    set.types.push_back(t);
  }
  CHECK(set.pick(6.0).name == "truck");  // ranges are [min, max)
  CHECK(set.pick(5.999).name == "car");
  VoxelGrid grid;
  const VehicleInsertStats st = insert_vehicles(grid, s, 0, set);
  CHECK(st.vehicles == 3);
  CHECK(st.per_type == std::vector<size_t>{1, 1, 1});
  VoteOptions vo;
  vo.class_id = static_cast<uint8_t>(SemanticClass::Truck);
  const auto truck_cells = voxelize_vehicle(block({1, 1, 1}), truck, 2, vo);
  const auto hist = grid.class_histogram();
  CHECK(hist[static_cast<size_t>(SemanticClass::Car)] == voxelize_vehicle(builtin_car_mesh(), car, 1).size());
  CHECK(hist[static_cast<size_t>(SemanticClass::Truck)] == truck_cells.size());
  CHECK(hist[static_cast<size_t>(SemanticClass::Bus)] > 0);
  CHECK(st.voxels == grid.voxel_count());
  for (const auto& c : truck_cells) CHECK(grid.get(c.ijk).instance == 2);
  CHECK_THROWS_AS(insert_vehicles(grid, s, 0, VehicleMeshSet{}), std::invalid_argument);
}

TEST_CASE("object_insert: the --box spec, with radians or degrees, and its one-line errors") {
  const BoxState b = parse_box_spec("1.5,-2,0.8,4.5,1.9,+1.6,0.5");
  CHECK(b.center == glm::dvec3(1.5, -2, 0.8));
  CHECK(b.length == 4.5);
  CHECK(b.width == 1.9);
  CHECK(b.height == 1.6);
  CHECK(b.heading == 0.5);
  CHECK(b.valid);
  CHECK(parse_box_spec("0,0,0,1,1,1,90deg").heading == doctest::Approx(std::numbers::pi / 2));
  const std::tuple<const char*, const char*> bad[] = {
      {"1,2,3", "got 3"},
      {"1,2,3,4,5,6,7,8", "got more"},
      {"1,,3,4,5,6,7", "cy '' is not a number"},
      {"1,2,3,4,5,6,east", "heading 'east' is not a number"},
      {"1,2,3,4m,5,6,7", "length '4m' is not a number"},
      {"1,2\n,3,4,5,6,7", "'1,2?,3,4,5,6,7': cy '2?' is not a number"},  // one line whatever the input
      {"nan,2,3,4,5,6,7", "cx is not finite"},
      {"1,2,3,4,inf,6,7", "width is not finite"},
      {"1,2,3,4,5,6,nandeg", "heading is not finite"},
      {"1,2,3,0,5,6,7", "length must be positive"},
      {"1,2,3,4,5,-6,7", "height must be positive"},
  };
  for (const auto& [text, want] : bad) {
    CAPTURE(text);
    const std::string msg = error_of([&] { parse_box_spec(text); });
    CHECK(msg.find(want) != std::string::npos);
    CHECK(msg.find('\n') == std::string::npos);
  }
  CHECK(error_of([] { parse_box_spec(""); }) == "'': cx '' is not a number");
}

TEST_CASE("object_insert: one object, existing voxels win unless overwritten, the next free instance id") {
  const TriangleMesh car = builtin_car_mesh();
  const BoxState b = box({0.3, -0.1, 0.8}, 4.5, 1.9, 1.6, 0.5);
  const auto cells = voxelize_vehicle(car, b, 1);
  REQUIRE(cells.size() > 100);
  VoxelGrid grid;
  CHECK(next_instance_id(grid) == 1);
  const glm::ivec3 taken = cells[cells.size() / 2].ijk;
  grid.set(taken, static_cast<uint8_t>(SemanticClass::Building), 41);
  CHECK(next_instance_id(grid) == 42);

  VoxelGrid kept = grid;
  const ObjectInsertResult r = insert_object(kept, car, b);
  CHECK(r.instance_id == 42);
  CHECK(r.cells == cells.size());
  CHECK(r.kept_existing == 1);
  CHECK(r.replaced == 0);
  CHECK(r.written == cells.size() - 1);
  CHECK(kept.get(taken).class_id == static_cast<uint8_t>(SemanticClass::Building));
  CHECK(kept.voxel_count() == cells.size());
  for (const auto& c : cells)
    if (c.ijk != taken) CHECK(kept.get(c.ijk).instance == 42);

  ObjectInsertOptions o;
  o.overwrite = true;
  o.class_id = static_cast<uint8_t>(SemanticClass::Bus);
  o.instance_id = 7;
  const ObjectInsertResult w = insert_object(grid, car, b, o);
  CHECK(w.replaced == 1);
  CHECK(w.written == cells.size());
  CHECK(grid.get(taken).class_id == static_cast<uint8_t>(SemanticClass::Bus));
  CHECK(grid.get(taken).instance == 7);

  BoxState flat = b;
  flat.height = 0.0;
  CHECK_THROWS_AS(insert_object(grid, car, flat), std::invalid_argument);
  BoxState nan = b;
  nan.heading = std::nan("");
  CHECK_THROWS_AS(insert_object(grid, car, nan), std::invalid_argument);
  BoxState huge = b;
  huge.length = huge.width = 1e6;  // 10^14 sub-voxels: refused before anything is allocated
  CHECK(error_of([&] { insert_object(grid, car, huge); }).find("1e+06 x 1e+06 x 1.6 m box spans") !=
        std::string::npos);
  o.class_id = 0;
  CHECK_THROWS_AS(insert_object(grid, car, b, o), std::invalid_argument);
  VoxelGrid full;
  full.set({0, 0, 0}, 1, 0xFFFF);
  CHECK_THROWS_AS(next_instance_id(full), std::invalid_argument);
}
