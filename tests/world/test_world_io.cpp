// .icw world files (round trip, byte-identical re-save, corrupt inputs),
// point import (majority vote, npy and PLY ascii/binary, bad rows) and export
// (PLY points read back, GLB face counts and precision 100 km from (0, 0, 0)).
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/input_error.h"
#include "world/npy.h"
#include "world/point_import.h"
#include "world/world_export.h"
#include "world/world_file.h"

#include <nlohmann/json.hpp>

// Declarations only: the implementation lives in engine/world/world_export.cpp.
#include "world/tinygltf_include.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>

#include <unistd.h>

using namespace icube;
using world::VoxelGrid;

namespace {

VoxelGrid random_world(uint32_t seed, int n, const glm::dvec3& origin = glm::dvec3(0.0)) {
  VoxelGrid g(origin);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(-70, 70), c(1, 22), inst(0, 65535);
  for (int i = 0; i < n; ++i)
    g.set({d(rng), d(rng), d(rng) / 4}, static_cast<uint8_t>(c(rng)), static_cast<uint16_t>(inst(rng)));
  g.set({world::kMaxIjk, -world::kMaxIjk - 1, 0}, 22, 65535);
  return g;
}

bool same_world(const VoxelGrid& a, const VoxelGrid& b) {
  if (a.voxel_count() != b.voxel_count() || a.brick_count() != b.brick_count() || a.origin() != b.origin() ||
      a.voxel_size() != b.voxel_size())
    return false;
  bool same = true;
  a.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    const world::Voxel w = b.get(ijk);
    same = same && w.class_id == v.class_id && w.instance == v.instance;
  });
  return same;
}

std::string error_of(const std::string& bytes) {
  try {
    world::world_from_bytes(bytes, "w.icw");
  } catch (const scene::InputError& e) {
    return e.what();
  }
  return "";
}

std::filesystem::path temp_dir() {
  auto p = std::filesystem::temp_directory_path() / ("icube_world_io_" + std::to_string(::getpid()));
  std::filesystem::create_directories(p);
  return p;
}

template <class T>
T read_le(const std::string& s, size_t at) {
  T v;
  std::memcpy(&v, s.data() + at, sizeof(T));
  return v;
}

}  // namespace

TEST_CASE("crc32 matches the standard check value") {
  CHECK(world::crc32("123456789") == 0xCBF43926u);
  CHECK(world::crc32("") == 0u);
  CHECK(world::crc32("6789", world::crc32("12345")) == 0xCBF43926u);
}

TEST_CASE(".icw round trip is exact and re-saving is byte-identical") {
  const VoxelGrid g = random_world(3, 20000, glm::dvec3(123456.789012345, -98765.4321, 0.1 + 1e-12));
  const std::string bytes = world::world_to_bytes(g);
  const VoxelGrid back = world::world_from_bytes(bytes, "mem.icw");
  CHECK(same_world(g, back));
  CHECK(world::world_to_bytes(back) == bytes);
  // Through the file system, atomically.
  const auto dir = temp_dir();
  const std::string path = (dir / "w.icw").string();
  world::save_world(g, path);
  CHECK(world::world_to_bytes(world::load_world(path)) == bytes);
  // Expected size: header + per brick (12 + 64) + 3 bytes per voxel + CRC.
  CHECK(bytes.size() == world::kWorldHeaderBytes + g.brick_count() * 76 + g.voxel_count() * 3 + 4);
  // Empty world.
  const VoxelGrid empty;
  CHECK(world::world_from_bytes(world::world_to_bytes(empty), "e").voxel_count() == 0);
  std::filesystem::remove_all(dir);
}

TEST_CASE(".icw corrupt files are InputErrors with byte offsets") {
  VoxelGrid g;
  g.set({1, 2, 3}, 5, 9);
  g.set({-100, 2, 3}, 6, 10);
  const std::string good = world::world_to_bytes(g);
  auto fix_crc = [](std::string s) {
    const uint32_t c = world::crc32(std::string_view(s).substr(0, s.size() - 4));
    std::memcpy(s.data() + s.size() - 4, &c, 4);
    return s;
  };
  // Truncated anywhere.
  for (size_t n : {size_t{0}, size_t{3}, size_t{8}, size_t{30}, good.size() - 1, good.size() - 5}) {
    CAPTURE(n);
    CHECK(!error_of(good.substr(0, n)).empty());
  }
  CHECK(error_of(good.substr(0, 30)).find("truncated") != std::string::npos);
  // Flipped byte -> CRC.
  std::string flip = good;
  flip[60] ^= 0x10;
  CHECK(error_of(flip).find("CRC32 mismatch") != std::string::npos);
  CHECK(error_of(flip).find("byte " + std::to_string(good.size() - 4)) != std::string::npos);
  // Bad magic and version.
  std::string magic = good;
  magic[0] = 'X';
  CHECK(error_of(magic).find("byte 0: not an icube world file") != std::string::npos);
  std::string ver = good;
  ver[4] = 7;
  CHECK(error_of(fix_crc(ver)).find("unsupported .icw version 7") != std::string::npos);
  // Huge brick count (valid CRC) is refused before allocating.
  std::string huge = good;
  const uint64_t big = uint64_t{1} << 60;
  std::memcpy(huge.data() + 40, &big, 8);
  CHECK(error_of(fix_crc(huge)).find("byte 40: brick count 1152921504606846976 exceeds") != std::string::npos);
  // Class id 23 (valid CRC): first brick's class byte is at 48 + 76.
  std::string cls = good;
  cls[48 + 76] = 23;
  CHECK(error_of(fix_crc(cls)).find("byte 124: brick 0: class id 23 is outside 1..22") != std::string::npos);
  // Empty mask.
  std::string mask = good;
  std::memset(mask.data() + 48 + 12, 0, 64);
  CHECK(error_of(fix_crc(mask)).find("is empty") != std::string::npos);
  // Duplicate brick: second brick coordinate := first.
  std::string dup = good;
  std::memcpy(dup.data() + 48 + 79, dup.data() + 48, 12);
  CHECK(error_of(fix_crc(dup)).find("appears twice") != std::string::npos);
  // Brick coordinate beyond +-2^20 (its voxels would pass the int32 ijk range).
  std::string far = good;
  const int32_t bx = 1 << 20;
  std::memcpy(far.data() + 48, &bx, 4);
  CHECK(error_of(fix_crc(far)).find("byte 48: brick 0: coordinate outside") != std::string::npos);
  // Bad voxel size.
  std::string vs = good;
  const double neg = -0.2;
  std::memcpy(vs.data() + 32, &neg, 8);
  CHECK(error_of(fix_crc(vs)).find("byte 32: voxel size") != std::string::npos);
  // Missing file.
  CHECK_THROWS_AS(world::load_world("/nonexistent/w.icw"), scene::InputError);
}

TEST_CASE("import: majority vote per voxel, ties to the lowest class and instance") {
  std::vector<world::LabeledPoint> pts;
  auto add = [&](double x, double y, double z, uint8_t c, uint16_t i) { pts.push_back({{x, y, z}, c, i}); };
  // Voxel (0,0,0): classes 7,7,3,3,9 -> tie 7 vs 3 -> 3; instances of class 3: 40, 30 -> tie -> 30.
  add(0.01, 0.01, 0.01, 7, 1);
  add(0.02, 0.19, 0.05, 7, 1);
  add(0.11, 0.11, 0.11, 3, 40);
  add(0.19, 0.01, 0.19, 3, 30);
  add(0.10, 0.10, 0.10, 9, 2);
  // Voxel (-1,0,0): class 14 x3 with instances 5,6,6 -> 14 / 6; class 15 x2.
  add(-0.05, 0.1, 0.1, 14, 5);
  add(-0.15, 0.1, 0.1, 14, 6);
  add(-0.01, 0.1, 0.1, 14, 6);
  add(-0.10, 0.1, 0.1, 15, 1);
  add(-0.10, 0.1, 0.1, 15, 1);
  // Voxel (5,5,5) with one point.
  add(1.05, 1.05, 1.05, 22, 0);
  const VoxelGrid g = world::voxelize_points(pts, glm::dvec3(0.0), 0.2, "mem");
  CHECK(g.voxel_count() == 3);
  CHECK(g.get({0, 0, 0}).class_id == 3);
  CHECK(g.get({0, 0, 0}).instance == 30);
  CHECK(g.get({-1, 0, 0}).class_id == 14);
  CHECK(g.get({-1, 0, 0}).instance == 6);
  CHECK(g.get({5, 5, 5}).class_id == 22);
}

TEST_CASE("import: npy N x 4 / N x 5 in float32 and float64, with bad rows rejected") {
  const auto dir = temp_dir();
  const std::string p4 = (dir / "p4.npy").string(), p5 = (dir / "p5.npy").string();
  // Class 0 rows are ignored; 100 km origin with float64 input.
  const glm::dvec3 o(100000.0, 200000.0, -5.0);
  world::write_npy(p5, world::NpyArray::make<double>({3, 5}, {o.x + 0.05, o.y + 0.05, o.z + 0.05, 18, 12,  //
                                                             o.x + 0.15, o.y + 0.15, o.z + 0.15, 18, 12,  //
                                                             o.x + 0.45, o.y + 0.05, o.z + 0.05, 0, 0}));
  world::ImportStats st;
  VoxelGrid g = world::import_points(p5, o, 0.2, &st);
  CHECK(st.points == 3);
  CHECK(st.labelled_points == 2);
  CHECK(g.voxel_count() == 1);
  CHECK(g.get({0, 0, 0}).class_id == 18);
  CHECK(g.get({0, 0, 0}).instance == 12);
  world::write_npy(p4, world::NpyArray::make<float>({2, 4}, {0.1f, 0.1f, 0.1f, 1.0f, -0.3f, 0.1f, 0.1f, 2.0f}));
  g = world::import_points(p4, glm::dvec3(0.0));
  CHECK(g.voxel_count() == 2);
  CHECK(g.get({-2, 0, 0}).class_id == 2);
  auto err = [&](const world::NpyArray& a) {
    world::write_npy(p4, a);
    try {
      world::import_points(p4, glm::dvec3(0.0));
    } catch (const scene::InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const float nan = std::nanf("");
  CHECK(err(world::NpyArray::make<float>({2, 4}, {0, 0, 0, 1, 0, nan, 0, 1})).find("row 1: coordinate is NaN") !=
        std::string::npos);
  CHECK(err(world::NpyArray::make<float>({1, 4}, {0, 0, 0, 23})).find("row 0: class 23") != std::string::npos);
  CHECK(err(world::NpyArray::make<float>({1, 4}, {0, 0, 0, 1.5f})).find("row 0: class 1.5") != std::string::npos);
  CHECK(err(world::NpyArray::make<float>({1, 3}, {0, 0, 0})).find("shape (N, 4) or (N, 5)") != std::string::npos);
  CHECK(err(world::NpyArray::make<int32_t>({1, 4}, {0, 0, 0, 1})).find("<f4 or <f8") != std::string::npos);
  CHECK(err(world::NpyArray::make<double>({1, 4}, {1e7, 0, 0, 1})).find("point 0") != std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("import: PLY ascii and binary little-endian") {
  const std::string ascii =
      "ply\nformat ascii 1.0\ncomment hand-made\nelement vertex 4\nproperty double x\nproperty double y\n"
      "property double z\nproperty uchar label\nproperty int instance\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n"
      "0.05 0.05 0.05 14 3\n0.1 0.1 0.1 14 4\n0.15 0.15 0.15 15 9\n-0.5 -0.5 -0.5 0 0\n3 0 1 2\n";
  uint64_t rows = 0;
  auto pts = world::points_from_ply_bytes(ascii, "a.ply", &rows);
  CHECK(rows == 4);
  REQUIRE(pts.size() == 3);
  VoxelGrid g = world::voxelize_points(pts, glm::dvec3(0.0), 0.2, "a.ply");
  CHECK(g.voxel_count() == 1);
  CHECK(g.get({0, 0, 0}).class_id == 14);
  CHECK(g.get({0, 0, 0}).instance == 3);

  // Binary: a face element first (must be skipped), then float xyz, float class, no instance.
  std::string bin = "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
                    "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                    "property float semantic\nend_header\n";
  bin += '\x02';
  for (int32_t i : {7, 8}) bin.append(reinterpret_cast<const char*>(&i), 4);
  for (float f : {1.0f, 2.0f, 3.0f, 10.0f, -1.0f, -2.0f, -3.0f, 11.0f}) bin.append(reinterpret_cast<const char*>(&f), 4);
  pts = world::points_from_ply_bytes(bin, "b.ply");
  REQUIRE(pts.size() == 2);
  g = world::voxelize_points(pts, glm::dvec3(0.0), 0.2, "b.ply");
  CHECK(g.get({5, 10, 15}).class_id == 10);
  CHECK(g.get({-5, -10, -15}).class_id == 11);

  auto err = [](const std::string& s) {
    try {
      world::points_from_ply_bytes(s, "x.ply");
    } catch (const scene::InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(err(bin.substr(0, bin.size() - 3)).find("row 1 at byte") != std::string::npos);
  std::string be = bin;
  be.replace(be.find("binary_little_endian"), 20, "binary_big_endian");
  CHECK(err(be).find("not supported") != std::string::npos);
  std::string nolabel = ascii;
  nolabel.replace(nolabel.find("uchar label"), 11, "uchar other");
  CHECK(err(nolabel).find("no 'class', 'label' or 'semantic'") != std::string::npos);
  std::string inf = ascii;
  inf.replace(inf.find("0.1 0.1 0.1"), 3, "inf");
  CHECK(err(inf).find("x.ply: row 1: coordinate is NaN or infinite") != std::string::npos);
  CHECK(err("ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar class\nend_header\n1 2 3 4\n")
            .find("exceeds the file") != std::string::npos);
}

TEST_CASE("export: PLY reads back with the origin, colours, classes and instances") {
  const glm::dvec3 origin(100000.123456789, -200000.987654321, 33.3);
  VoxelGrid g(origin);
  g.set({0, 0, 0}, 18, 0);
  g.set({10, -3, 2}, 1, 10001);
  g.set({-7, 4, 0}, 14, 5);
  world::ExportStats st;
  const std::string ply = world::world_to_ply_bytes(g, &st);
  CHECK(st.points == 3);
  // Origin comment with full precision.
  const size_t c = ply.find("comment icube_origin ");
  REQUIRE(c != std::string::npos);
  double ox = 0, oy = 0, oz = 0;
  REQUIRE(std::sscanf(ply.c_str() + c, "comment icube_origin %lf %lf %lf", &ox, &oy, &oz) == 3);
  CHECK(ox == origin.x);
  CHECK(oy == origin.y);
  CHECK(oz == origin.z);
  // Through the importer: same classes/instances, positions within 1 mm after adding the origin.
  auto pts = world::points_from_ply_bytes(ply, "out.ply");
  REQUIRE(pts.size() == 3);
  std::vector<world::LabeledPoint> world_pts;
  for (auto p : pts) {
    p.position += glm::dvec3(ox, oy, oz);
    world_pts.push_back(p);
  }
  const VoxelGrid back = world::voxelize_points(world_pts, origin, 0.2, "out.ply");
  CHECK(same_world(g, back));
  size_t i = 0;
  g.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    const glm::dvec3 want = g.ijk_to_world(ijk);
    CHECK(glm::length(world_pts[i].position - want) < 1e-3);
    CHECK(world_pts[i].class_id == v.class_id);
    ++i;
  });
  // Colours: records of 18 bytes after the header; rgb at +12.
  const size_t body = ply.find("end_header\n") + 11;
  REQUIRE(ply.size() == body + 3 * 18);
  i = 0;
  g.for_each_voxel([&](const glm::ivec3&, const world::Voxel& v) {
    const auto rgb = world::class_color(v.class_id);
    CHECK(static_cast<uint8_t>(ply[body + i * 18 + 12]) == rgb[0]);
    CHECK(static_cast<uint8_t>(ply[body + i * 18 + 13]) == rgb[1]);
    CHECK(static_cast<uint8_t>(ply[body + i * 18 + 14]) == rgb[2]);
    CHECK(read_le<uint16_t>(ply, body + i * 18 + 16) == v.instance);
    ++i;
  });
}

namespace {

// Minimal GLB reader for the tests: JSON chunk + BIN chunk.
struct Glb {
  nlohmann::json json;
  std::string bin;
};

Glb parse_glb(const std::string& s) {
  Glb g;
  REQUIRE(s.size() >= 20);
  REQUIRE(s.compare(0, 4, "glTF") == 0);
  CHECK(read_le<uint32_t>(s, 8) == s.size());
  const uint32_t jlen = read_le<uint32_t>(s, 12);
  REQUIRE(read_le<uint32_t>(s, 16) == 0x4E4F534Au);  // "JSON"
  g.json = nlohmann::json::parse(s.substr(20, jlen));
  if (20 + jlen + 8 <= s.size()) {
    const uint32_t blen = read_le<uint32_t>(s, 20 + jlen);
    g.bin = s.substr(20 + jlen + 8, blen);
  }
  return g;
}

size_t glb_quads(const Glb& g) {
  size_t tris = 0;
  for (const auto& p : g.json["meshes"][0]["primitives"]) tris += g.json["accessors"][p["indices"].get<int>()]["count"].get<size_t>() / 3;
  return tris / 2;
}

}  // namespace

TEST_CASE("export: GLB greedy faces and precision 100 km from the origin") {
  VoxelGrid one;
  one.set({3, 3, 3}, 18);
  world::ExportStats st;
  Glb g = parse_glb(world::world_to_glb_bytes(one, &st));
  CHECK(st.quads == 6);
  CHECK(glb_quads(g) == 6);
  CHECK(g.json["meshes"][0]["primitives"].size() == 1);

  const glm::dvec3 origin(100000.0, -100000.0, 50.0);
  VoxelGrid two(origin);
  two.set({0, 0, 0}, 14);
  two.set({1, 0, 0}, 14);
  two.set({-40, 30, 2}, 1);  // a second class: second primitive
  g = parse_glb(world::world_to_glb_bytes(two, &st));
  CHECK(st.quads == 12);
  CHECK(st.primitives == 2);
  CHECK(glb_quads(g) == 12);
  const auto& node = g.json["nodes"][0];
  CHECK(node["translation"][0].get<double>() == origin.x);
  CHECK(node["translation"][1].get<double>() == origin.y);
  CHECK(node["translation"][2].get<double>() == origin.z);
  // The building primitive's vertices, plus the node translation, are the block's corners to < 1 mm.
  const auto& prims = g.json["meshes"][0]["primitives"];
  bool found = false;
  for (const auto& p : prims) {
    const auto& mat = g.json["materials"][p["material"].get<int>()];
    if (mat["name"] != "building") continue;
    found = true;
    const auto rgb = world::class_color(14);
    CHECK(mat["pbrMetallicRoughness"]["baseColorFactor"][0].get<double>() == doctest::Approx(rgb[0] / 255.0));
    const auto& acc = g.json["accessors"][p["attributes"]["POSITION"].get<int>()];
    const auto& view = g.json["bufferViews"][acc["bufferView"].get<int>()];
    const size_t off = view.value("byteOffset", size_t{0});
    const size_t n = acc["count"].get<size_t>();
    CHECK(n == 24);
    double max_err = 0.0;
    for (size_t v = 0; v < n; ++v) {
      glm::dvec3 w;
      for (int a = 0; a < 3; ++a) w[a] = origin[a] + static_cast<double>(read_le<float>(g.bin, off + (v * 3 + static_cast<size_t>(a)) * 4));
      // Expected corners lie on the 0.2 m lattice of [0, 0.4] x [0, 0.2] x [0, 0.2] about the origin.
      const glm::dvec3 rel = (w - origin) / 0.2;
      for (int a = 0; a < 3; ++a) max_err = std::max(max_err, std::abs(rel[a] - std::round(rel[a])) * 0.2);
      CHECK(std::round(rel.x) >= 0);
      CHECK(std::round(rel.x) <= 2);
    }
    CHECK(max_err < 1e-3);
  }
  CHECK(found);
  // tinygltf's own loader accepts the file (accessor and buffer-view bounds are checked there).
  const std::string glb = world::world_to_glb_bytes(two);
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string gerr, gwarn;
  CHECK(loader.LoadBinaryFromMemory(&model, &gerr, &gwarn, reinterpret_cast<const unsigned char*>(glb.data()),
                                    static_cast<unsigned int>(glb.size())));
  CHECK(gerr.empty());
  CHECK(model.meshes.size() == 1);
  CHECK(model.materials.size() == 2);
  // Empty world still makes a valid GLB.
  g = parse_glb(world::world_to_glb_bytes(VoxelGrid{}));
  CHECK(g.json["nodes"].size() == 1);
  CHECK_THROWS_AS(world::export_world(one, "x.obj"), std::invalid_argument);
}

TEST_CASE("import: a real Blender PLY without labels is refused with a clear message") {
  const std::string dir = test::test_data_dir();
  if (dir.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  const std::string path = dir + "/meshes/car.ply";
  try {
    world::import_points(path, glm::dvec3(0.0));
    FAIL("car.ply has no class property and must be refused");
  } catch (const scene::InputError& e) {
    CHECK(std::string(e.what()) == path + ": header: vertex element has no 'class', 'label' or 'semantic' property");
  }
}
