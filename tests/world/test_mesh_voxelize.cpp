// Vehicle voxelisation (engine/world/mesh_voxelize.h, car_mesh.h,
// vehicle_insert.cpp): exact sub-voxel and cell counts for a cube, a rotated
// box's footprint and volume, degenerate boxes, the built-in car (watertight,
// fill fraction, its committed OBJ asset), the real car.ply when present,
// shift invariance 100 km from the origin, and insertion into a VoxelGrid.
#include "world/car_mesh.h"
#include "world/mesh_voxelize.h"
#include "world/voxel_grid.h"

#include "gpu_test_context.h"
#include "scene/atomic_file.h"
#include "scene/frames.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <numbers>
#include <set>

using namespace icube::world;
using icube::scene::BoxState;

namespace {

// An axis-aligned cube [lo, lo + size]^3, outward wound.
TriangleMesh cube_mesh(double lo = -0.5, double size = 1.0) {
  TriangleMesh m;
  for (int k = 0; k < 8; ++k) m.positions.push_back(glm::dvec3(k & 1, (k >> 1) & 1, (k >> 2) & 1) * size + lo);
  const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

BoxState box(glm::dvec3 c, double l, double w, double h, double heading = 0.0) {
  BoxState b;
  b.center = c, b.length = l, b.width = w, b.height = h, b.heading = heading, b.valid = true;
  return b;
}

using Key = std::tuple<int, int, int>;
Key key(const glm::ivec3& v) { return {v.x, v.y, v.z}; }

// Every directed edge exactly once and its reverse exactly once.
bool watertight(const TriangleMesh& m, size_t& edges) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  edges = directed.size() / 2;
  for (const auto& [e, n] : directed) {
    const auto rev = directed.find({e.second, e.first});
    if (n != 1 || rev == directed.end() || rev->second != 1) return false;
  }
  return true;
}

double signed_volume(const TriangleMesh& m) {
  double v = 0.0;
  for (const auto& t : m.triangles)
    v += glm::dot(m.positions[t.x], glm::cross(m.positions[t.y], m.positions[t.z])) / 6.0;
  return v;
}

}  // namespace

TEST_CASE("mesh_voxelize: a unit cube in a 1 m box gives 10^3 sub-voxels and the expected 0.2 m cells") {
  // Any placement of the cube mesh is fitted to the box.
  for (const TriangleMesh& mesh : {cube_mesh(), cube_mesh(-3.0, 7.0)}) {
    const BoxVoxelization v = voxelize_mesh_in_box(mesh, 1.0, 1.0, 1.0);
    REQUIRE(v.sub_voxels.size() == 1000);
    CHECK(v.surface == 1000 - 512);  // the outer layer
    CHECK(v.interior == 512);
    std::set<Key> s;
    for (const auto& ijk : v.sub_voxels) s.insert(key(ijk));
    CHECK(s.size() == 1000);
    CHECK(*s.begin() == Key{-5, -5, -5});
    CHECK(*s.rbegin() == Key{4, 4, 4});
  }
  // Box on the 0.2 m lattice: 5 x 5 x 5 cells of exactly 8 sub-voxels.
  const auto aligned = voxelize_vehicle(cube_mesh(), box({0.1, 0.1, 0.5}, 1, 1, 1), 7);
  REQUIRE(aligned.size() == 125);
  for (const auto& c : aligned) {
    CHECK(c.sub_voxels == 8);
    CHECK(c.class_id == 1);
    CHECK(c.instance_id == 7);
  }
  CHECK(aligned.front().ijk == glm::ivec3(-2, -2, 0));
  CHECK(aligned.back().ijk == glm::ivec3(2, 2, 4));
  // Half a cell off in x and y: 6 x 6 x 5 cells; the rim cells get 1 x 2 (x 2 in z) sub-voxels per axis.
  const auto off = voxelize_vehicle(cube_mesh(), box({0.0, 0.0, 0.5}, 1, 1, 1), 7);
  CHECK(off.size() == 180);
  uint32_t total = 0, corners = 0;
  for (const auto& c : off) {
    total += c.sub_voxels;
    corners += c.sub_voxels == 2;
    CHECK(c.ijk.x >= -3);
    CHECK(c.ijk.x <= 2);
    CHECK(c.ijk.z >= 0);
    CHECK(c.ijk.z <= 4);
  }
  CHECK(total == 1000);
  CHECK(corners == 4 * 5);
  VoteOptions three;
  three.min_sub_voxels = 3;
  CHECK(voxelize_vehicle(cube_mesh(), box({0.0, 0.0, 0.5}, 1, 1, 1), 7, three).size() == 160);
}

TEST_CASE("mesh_voxelize: a box at heading 30 degrees stays in its footprint and keeps its volume") {
  // Box bottom on the 0.2 m lattice (z = 0) with the default rule (>= 1) and the half-of-8 rule (>= 4);
  // off the lattice (bottom at z = 0.1) only >= 4 stays within 10 % (>= 1 gains a ninth cell layer: +21 %).
  const double dilate = 0.1 * std::sqrt(2.0) + 1e-9;  // half a cell diagonal in x-y
  const std::tuple<double, uint32_t> cases[] = {{0.8, 1u}, {0.8, 4u}, {0.9, 4u}};
  for (const auto& [cz, min_sub] : cases) {
    const BoxState b = box({3.3, -1.7, cz}, 4.0, 2.0, 1.6, std::numbers::pi / 6.0);
    const glm::dmat4 to_box = glm::inverse(icube::scene::box_to_world(b));
    VoteOptions opt;
    opt.min_sub_voxels = min_sub;
    const auto cells = voxelize_vehicle(cube_mesh(), b, 3, opt);
    size_t outside = 0;
    for (const auto& c : cells) {
      const glm::dvec3 p = glm::dvec3(to_box * glm::dvec4((glm::dvec3(c.ijk) + 0.5) * 0.2, 1.0));
      outside += std::abs(p.x) > 2.0 + dilate || std::abs(p.y) > 1.0 + dilate || std::abs(p.z) > 0.8 + 0.1 + 1e-9;
    }
    CHECK(outside == 0);
    const double got = static_cast<double>(cells.size()) * 0.008, volume = 4.0 * 2.0 * 1.6;
    MESSAGE("heading 30, centre z " << cz << ", min_sub_voxels " << min_sub << ": " << cells.size() << " cells, "
                                    << got << " m^3 vs " << volume << " m^3 (" << 100.0 * (got / volume - 1.0)
                                    << " %)");
    CHECK(std::abs(got / volume - 1.0) < 0.10);
  }
  const BoxState b = box({3.3, -1.7, 0.8}, 4.0, 2.0, 1.6, std::numbers::pi / 6.0);
  // The vote equals transforming every sub-voxel centre with box_to_world directly.
  const BoxVoxelization v = voxelize_mesh_in_box(cube_mesh(), b.length, b.width, b.height);
  CHECK(v.sub_voxels.size() == 40 * 20 * 16);
  std::map<Key, uint32_t> direct;
  const glm::dmat4 to_world = icube::scene::box_to_world(b);
  for (const auto& s : v.sub_voxels) {
    const glm::dvec3 p = glm::dvec3(to_world * glm::dvec4((glm::dvec3(s) + 0.5) * 0.1, 1.0));
    ++direct[key(glm::ivec3(glm::floor(p / 0.2)))];
  }
  const auto cells = vote_into_cells(v, b, 3);
  REQUIRE(cells.size() == direct.size());
  size_t same = 0;
  for (const auto& c : cells) same += direct[key(c.ijk)] == c.sub_voxels;
  CHECK(same == cells.size());
}

TEST_CASE("mesh_voxelize: degenerate boxes and flat meshes do not crash") {
  // A box with no volume gives no voxels (documented: Waymo has zero-height boxes).
  CHECK(voxelize_vehicle(cube_mesh(), box({0, 0, 0}, 4, 2, 0), 1).empty());
  CHECK(voxelize_vehicle(cube_mesh(), box({0, 0, 0}, 4, -2, 1), 1).empty());
  CHECK(voxelize_vehicle(cube_mesh(), box({0, 0, 0}, NAN, 2, 1), 1).empty());
  CHECK(voxelize_vehicle(TriangleMesh{}, box({0, 0, 0}, 4, 2, 1), 1).empty());
  CHECK(voxelize_mesh_in_box(cube_mesh(), 0.04, 1, 1).sub_voxels.empty());  // thinner than one sub-voxel pitch
  // A flat square lands on the box mid-plane z = 0, the face between sub-voxel layers -1 and 0: both are surface.
  TriangleMesh flat;
  flat.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  flat.triangles = {{0, 1, 2}, {0, 2, 3}};
  const BoxVoxelization v = voxelize_mesh_in_box(flat, 1, 1, 1);
  CHECK(v.surface == 200);
  CHECK(v.interior == 0);
  // A far-out-of-range centre is refused, not wrapped.
  CHECK_THROWS_AS(voxelize_vehicle(cube_mesh(), box({1e12, 0, 0}, 1, 1, 1), 1), std::out_of_range);
}

TEST_CASE("mesh_voxelize: the built-in car is watertight and fills 50-90 % of its box") {
  const TriangleMesh car = builtin_car_mesh();
  size_t edges = 0;
  CHECK(watertight(car, edges));
  CHECK(signed_volume(car) > 0.0);  // outward winding
  CHECK(car.triangles.size() >= 200);
  CHECK(car.triangles.size() <= 800);
  const MeshBounds b = mesh_bounds(car);
  const glm::dvec3 ext = b.max - b.min;
  CHECK(b.min.z == doctest::Approx(0.0));
  const BoxVoxelization v = voxelize_mesh_in_box(car, 4.5, 1.8, 1.45);
  const double fill = static_cast<double>(v.sub_voxels.size()) * 1e-3 / (4.5 * 1.8 * 1.45);
  MESSAGE("builtin car: " << car.positions.size() << " vertices, " << car.triangles.size() << " triangles, " << edges
                          << " edges, extent " << ext.x << " x " << ext.y << " x " << ext.z << " m, mesh volume "
                          << signed_volume(car) << " m^3; in 4.5 x 1.8 x 1.45: " << v.sub_voxels.size()
                          << " sub-voxels (" << v.surface << " surface, " << v.interior << " interior), fill "
                          << fill);
  CHECK(v.interior > v.surface / 2);  // the flood fill found an inside
  CHECK(fill > 0.5);
  CHECK(fill < 0.9);
}

TEST_CASE("mesh_voxelize: assets/car_simple.obj is builtin_car_mesh() exported as OBJ") {
  const std::string path = std::string(ICUBE_SOURCE_DIR) + "/assets/car_simple.obj";
  const std::string want = mesh_to_obj(builtin_car_mesh(), car_mesh_obj_header());
  const char* update = std::getenv("ICUBE_UPDATE_ASSETS");
  if (update && std::string(update) == "1") {
    icube::scene::write_file_atomic(path, want);
    MESSAGE("rewrote " << path << " (" << want.size() << " bytes)");
  }
  const std::string got = icube::scene::read_file(path);
  CHECK(got.size() < 100 * 1024);
  CHECK_MESSAGE(got == want, "assets/car_simple.obj is stale: regenerate with ICUBE_UPDATE_ASSETS=1");
  const TriangleMesh back = parse_obj(got, path);
  CHECK(back.triangles == builtin_car_mesh().triangles);
}

TEST_CASE("mesh_voxelize: the InfiniCube car.ply voxelises to a plausible car") {
  const std::string dir = icube::test::test_data_dir();
  if (dir.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  const TriangleMesh car = load_mesh(dir + "/meshes/car.ply");
  size_t edges = 0;
  const bool closed = watertight(car, edges);
  const BoxVoxelization v = voxelize_mesh_in_box(car, 3.80, 1.84, 1.49);
  const double fill = static_cast<double>(v.sub_voxels.size()) * 1e-3 / (3.80 * 1.84 * 1.49);
  const auto cells = voxelize_vehicle(car, box({0.1, 0.1, 0.745}, 3.80, 1.84, 1.49), 1);
  MESSAGE("car.ply: watertight " << closed << "; " << v.sub_voxels.size() << " sub-voxels (" << v.surface
                                 << " surface, " << v.interior << " interior), fill " << fill << ", "
                                 << cells.size() << " cells of 0.2 m");
  CHECK(fill > 0.3);
  CHECK(fill < 0.95);
  CHECK(cells.size() > 500);
}

TEST_CASE("mesh_voxelize: a car 100 km from the origin gives the same cells shifted") {
  const TriangleMesh car = builtin_car_mesh();
  const BoxState near_box = box({0.37, -1.21, 0.9}, 4.6, 1.9, 1.5, 0.5236);
  BoxState far_box = near_box;
  far_box.center += glm::dvec3(100000.0, -100000.0, 0.0);
  const auto a = voxelize_vehicle(car, near_box, 5);
  const auto b = voxelize_vehicle(car, far_box, 5);
  REQUIRE(a.size() == b.size());
  REQUIRE(!a.empty());
  size_t same = 0;
  for (size_t i = 0; i < a.size(); ++i)
    same += b[i].ijk == a[i].ijk + glm::ivec3(500000, -500000, 0) && b[i].sub_voxels == a[i].sub_voxels;
  CHECK(same == a.size());
}

TEST_CASE("mesh_voxelize: insert_vehicles puts static cars of one state into a VoxelGrid") {
  icube::scene::Scene s;
  s.timestamps = {0.0, 0.1};
  auto track = [](int64_t id, icube::scene::ObjectType type, bool dynamic, uint32_t inst, BoxState b) {
    icube::scene::Track t;
    t.id = id, t.type = type, t.dynamic = dynamic, t.instance_id = inst;
    t.states = {b, b};
    return t;
  };
  const BoxState a = box({0.1, 0.1, 0.75}, 4.5, 1.8, 1.5), overlap = box({2.1, 0.1, 0.75}, 4.5, 1.8, 1.5);
  BoxState invalid = box({20, 0, 0.75}, 4.5, 1.8, 1.5);
  invalid.valid = false;
  s.tracks = {track(10, icube::scene::ObjectType::Vehicle, false, 2, overlap),
              track(11, icube::scene::ObjectType::Vehicle, false, 1, a),
              track(12, icube::scene::ObjectType::Vehicle, true, 10000, box({-20, 0, 0.75}, 4.5, 1.8, 1.5)),
              track(13, icube::scene::ObjectType::Pedestrian, false, 3, box({0, 20, 0.9}, 0.8, 0.8, 1.8)),
              track(14, icube::scene::ObjectType::Vehicle, false, 4, invalid)};
  const TriangleMesh car = builtin_car_mesh();
  const auto cells_a = voxelize_vehicle(car, a, 1), cells_b = voxelize_vehicle(car, overlap, 2);
  std::set<Key> ka, kb;
  for (const auto& c : cells_a) ka.insert(key(c.ijk));
  for (const auto& c : cells_b) kb.insert(key(c.ijk));
  size_t both = 0;
  for (const auto& k : kb) both += ka.count(k);
  REQUIRE(both > 0);

  VoxelGrid grid;
  const glm::ivec3 road = cells_a.front().ijk;
  grid.set(road, static_cast<uint8_t>(SemanticClass::Road));
  const uint64_t written = insert_vehicles(grid, s, 1, car);
  CHECK(written == ka.size() + kb.size() - both - 1);
  CHECK(grid.voxel_count() == written + 1);
  CHECK(grid.get(road).class_id == static_cast<uint8_t>(SemanticClass::Road));  // existing voxels win
  size_t id1 = 0, id2 = 0;
  grid.for_each_voxel([&](const glm::ivec3&, const Voxel& v) {
    if (v.class_id != 1) return;
    id1 += v.instance == 1;
    id2 += v.instance == 2;
  });
  CHECK(id1 == ka.size() - 1);  // the lower id keeps the shared cells
  CHECK(id2 == kb.size() - both);
  CHECK_THROWS_AS(insert_vehicles(grid, s, 2, car), std::out_of_range);
}
