// Mesh readers (engine/world/triangle_mesh.h): PLY ascii and binary (both
// endians, mixed property types, skipped elements), OBJ (relative indices,
// polygons), glTF/GLB built here with tinygltf (node transforms, default
// scene), malformed files -> one-line InputError naming file and place, and
// the real InfiniCube car.ply when the shared data is present.
#include "world/triangle_mesh.h"

#include "gpu_test_context.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include "world/tinygltf_include.h"

#include <doctest/doctest.h>

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <random>
#include <sstream>

using namespace icube::world;
using icube::scene::InputError;

namespace {

std::string tmp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("icube_mesh_" + std::to_string(getpid()) + "_" + name)).string();
}

// Writes `bytes` to a temporary file and loads it with load_mesh().
TriangleMesh load_bytes(const std::string& name, const std::string& bytes) {
  const std::string path = tmp_path(name);
  icube::scene::write_file_atomic(path, bytes);
  struct Remove {
    std::string p;
    ~Remove() { std::filesystem::remove(p); }
  } remove{path};
  return load_mesh(path);
}

// The InputError message of loading `bytes`, or "" when it loads.
std::string load_error(const std::string& name, const std::string& bytes) {
  try {
    load_bytes(name, bytes);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

template <class T>
void put(std::string& out, T v, bool big_endian) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

// A unit square (quad) plus one triangle, as binary PLY with double x, float
// y/z, an extra uchar property, a skipped "edge" element and an int-count list.
std::string binary_ply(bool big_endian, size_t truncate_by = 0) {
  std::string s = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\ncomment test\nelement vertex 5\nproperty double x\nproperty float y\nproperty float z\n"
                  "property uchar red\nelement edge 1\nproperty list uchar int pair\nelement face 2\n"
                  "property list int uint vertex_index\nend_header\n";
  const double xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 2.25}};
  for (const auto& v : xyz) {
    put<double>(s, v[0], big_endian);
    put<float>(s, static_cast<float>(v[1]), big_endian);
    put<float>(s, static_cast<float>(v[2]), big_endian);
    put<uint8_t>(s, 200, big_endian);
  }
  put<uint8_t>(s, 2, big_endian);
  put<int32_t>(s, 0, big_endian);
  put<int32_t>(s, 4, big_endian);
  put<int32_t>(s, 4, big_endian);
  for (uint32_t i : {0u, 1u, 2u, 3u}) put<uint32_t>(s, i, big_endian);
  put<int32_t>(s, 3, big_endian);
  for (uint32_t i : {0u, 1u, 4u}) put<uint32_t>(s, i, big_endian);
  s.resize(s.size() - truncate_by);
  return s;
}

void check_square_and_triangle(const TriangleMesh& m) {
  REQUIRE(m.positions.size() == 5);
  CHECK(m.positions[2] == glm::dvec3(1, 1, 0));
  CHECK(m.positions[4] == glm::dvec3(0.5, 0.5, 2.25));
  REQUIRE(m.triangles.size() == 3);
  CHECK(m.triangles[0] == glm::uvec3(0, 1, 2));  // quad fan
  CHECK(m.triangles[1] == glm::uvec3(0, 2, 3));
  CHECK(m.triangles[2] == glm::uvec3(0, 1, 4));
}

// A glTF model: one mesh (a triangle, ushort indices) used by two nodes of
// scene 1 (the default): a translated root and its scaled+rotated child.
// Scene 0 holds a third node that must be ignored.
std::string gltf_bytes(bool binary, uint16_t bad_index = 0) {
  tinygltf::Model model;
  std::vector<unsigned char> data;
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const uint16_t idx[4] = {0, 1, static_cast<uint16_t>(bad_index ? bad_index : 2), 0};  // padded to 4-byte alignment
  data.resize(sizeof pos + sizeof idx);
  std::memcpy(data.data(), pos, sizeof pos);
  std::memcpy(data.data() + sizeof pos, idx, sizeof idx);
  tinygltf::Buffer buffer;
  buffer.data = data;
  model.buffers.push_back(buffer);
  tinygltf::BufferView bv_pos, bv_idx;
  bv_pos.buffer = 0, bv_pos.byteOffset = 0, bv_pos.byteLength = sizeof pos;
  bv_idx.buffer = 0, bv_idx.byteOffset = sizeof pos, bv_idx.byteLength = 6;
  model.bufferViews = {bv_pos, bv_idx};
  tinygltf::Accessor a_pos, a_idx;
  a_pos.bufferView = 0, a_pos.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT, a_pos.count = 3,
  a_pos.type = TINYGLTF_TYPE_VEC3, a_pos.minValues = {0, 0, 0}, a_pos.maxValues = {1, 1, 0};
  a_idx.bufferView = 1, a_idx.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, a_idx.count = 3,
  a_idx.type = TINYGLTF_TYPE_SCALAR;
  model.accessors = {a_pos, a_idx};
  tinygltf::Primitive prim;
  prim.attributes["POSITION"] = 0;
  prim.indices = 1;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  tinygltf::Mesh mesh;
  mesh.primitives.push_back(prim);
  model.meshes.push_back(mesh);
  tinygltf::Node root, child, ignored;
  root.mesh = 0, root.translation = {10, 0, 0}, root.children = {1};
  child.mesh = 0, child.scale = {2, 2, 2}, child.rotation = {0, 0, std::sqrt(0.5), std::sqrt(0.5)};  // 90 deg about z
  ignored.mesh = 0, ignored.translation = {-50, 0, 0};
  model.nodes = {root, child, ignored};
  tinygltf::Scene s0, s1;
  s0.nodes = {2};
  s1.nodes = {0};
  model.scenes = {s0, s1};
  model.defaultScene = 1;
  model.asset.version = "2.0";
  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  REQUIRE(writer.WriteGltfSceneToStream(&model, out, false, binary));
  return out.str();
}

bool near3(const glm::dvec3& a, const glm::dvec3& b) { return glm::length(a - b) < 1e-6; }

}  // namespace

TEST_CASE("triangle_mesh: ascii PLY with a quad, a triangle and extra properties") {
  const std::string ply =
      "ply\r\nformat ascii 1.0\r\nelement vertex 5\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
      "property float nx\r\nelement face 2\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
      "0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n0.5 0.5 2.25 1\n4 0 1 2 3\n3 0 1 4\n";
  check_square_and_triangle(parse_ply(ply, "a.ply"));
  check_square_and_triangle(load_bytes("a.ply", ply));
}

TEST_CASE("triangle_mesh: binary PLY, little and big endian, mixed types, skipped element") {
  check_square_and_triangle(parse_ply(binary_ply(false), "le.ply"));
  check_square_and_triangle(parse_ply(binary_ply(true), "be.ply"));
  check_square_and_triangle(load_bytes("be.ply", binary_ply(true)));
}

TEST_CASE("triangle_mesh: OBJ with texture/normal refs, negative indices and polygons") {
  const std::string obj =
      "# comment\nmtllib x.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 1.0\nvt 0 0\nvn 0 0 1\n"
      "g grp\nusemtl m\ns off\nf 1/1/1 2/1/1 3/1/1 4/1/1\nv 0.5 0.5 2.25\nf -5//1 -4//1 -1//1  # trailing comment\n";
  check_square_and_triangle(parse_obj(obj, "a.obj"));
  check_square_and_triangle(load_bytes("a.obj", obj));
}

TEST_CASE("triangle_mesh: GLB and glTF with node transforms of the default scene") {
  for (bool binary : {true, false}) {
    CAPTURE(binary);
    const TriangleMesh m = load_bytes(binary ? "t.glb" : "t.gltf", gltf_bytes(binary));
    REQUIRE(m.positions.size() == 6);
    REQUIRE(m.triangles.size() == 2);
    // Root: translated by +10 x.
    CHECK(near3(m.positions[0], {10, 0, 0}));
    CHECK(near3(m.positions[1], {11, 0, 0}));
    CHECK(near3(m.positions[2], {10, 1, 0}));
    // Child: T(10) * R(90 deg z) * S(2): (1,0,0) -> (10, 2, 0), (0,1,0) -> (8, 0, 0).
    CHECK(near3(m.positions[3], {10, 0, 0}));
    CHECK(near3(m.positions[4], {10, 2, 0}));
    CHECK(near3(m.positions[5], {8, 0, 0}));
    CHECK(m.triangles[0] == glm::uvec3(0, 1, 2));
    CHECK(m.triangles[1] == glm::uvec3(3, 4, 5));
  }
  TriangleMesh up = load_bytes("t.glb", gltf_bytes(true));
  gltf_y_up_to_z_up(up);
  CHECK(near3(up.positions[2], {10, 0, 1}));  // glTF +y becomes +z
}

TEST_CASE("triangle_mesh: malformed files give one-line InputErrors with file and place") {
  auto one_line_with = [](const std::string& msg, const std::string& where) {
    INFO(msg);
    CHECK(msg.find('\n') == std::string::npos);
    CHECK(msg.find("icube_mesh_") != std::string::npos);  // the file
    CHECK(msg.find(where) != std::string::npos);
  };
  one_line_with(load_error("trunc.ply", binary_ply(false, 3)), "face 1: file ends early");
  one_line_with(load_error("trunc_be.ply", binary_ply(true, 30)), "face 0: file ends early");
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                           "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  one_line_with(load_error("idx.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"), "face 0 (line 13): vertex index 7 out of range");
  one_line_with(load_error("num.ply", head + "0 0 0\n1 zz 0\n0 1 0\n3 0 1 2\n"), "vertex 1 (line 11): bad number 'zz'");
  one_line_with(load_error("nan.ply", head + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"), "vertex 1 (line 11): coordinate is not finite");
  one_line_with(load_error("two.ply", head + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), "face 0 (line 13): face with 2 vertices");
  one_line_with(load_error("kw.ply", "ply\nformat ascii 1.0\nelemnt vertex 3\nend_header\n"), "header line 3: unknown header keyword");
  one_line_with(load_error("big.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
                                      "property float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\n"
                                      "end_header\n"),
                "element vertex: 4000000000 entries cannot fit");
  one_line_with(load_error("nohdr.ply", "ply\nformat ascii 1.0\nelement vertex 0\n"), "header: no end_header");
  one_line_with(load_error("ref.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 9\n"), "line 5: vertex reference 9 out of range");
  one_line_with(load_error("neg.obj", "v 0 0 0\nv 1 0 0\nf -3 1 2\n"), "line 3: vertex reference -3 out of range");
  one_line_with(load_error("coord.obj", "v 0 0 0\nv 1 x 0\n"), "line 2: bad coordinate 'x'");
  one_line_with(load_error("short.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n"), "line 3: face needs at least 3 vertices");
  one_line_with(load_error("idx.glb", gltf_bytes(true, 7)), "mesh 0 primitive 0: index 7 out of range");
  std::string glb = gltf_bytes(true);
  glb.resize(glb.size() / 2);
  one_line_with(load_error("half.glb", glb), "glTF");
  one_line_with(load_error("junk.gltf", "{ \"asset\": { \"version\": \"2.0\" }, \"meshes\": 3 "), "glTF");
  std::string draco = gltf_bytes(false);
  draco.insert(draco.find('{') + 1, R"("extensionsRequired": ["KHR_draco_mesh_compression"], )");
  one_line_with(load_error("draco.gltf", draco), "glTF: requires KHR_draco_mesh_compression (compressed geometry)");
  CHECK_THROWS_AS(load_mesh(tmp_path("does_not_exist.obj")), InputError);
}

TEST_CASE("triangle_mesh: mutated PLY and OBJ bytes load or throw InputError, never crash") {
  std::mt19937 rng(12345);
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf -4 -3 -1\n";
  const std::string seeds[] = {binary_ply(false), binary_ply(true), obj};
  size_t loaded = 0, rejected = 0;
  for (int round = 0; round < 3000; ++round) {
    std::string bytes = seeds[static_cast<size_t>(round) % 3];
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      const size_t at = rng() % bytes.size();
      switch (rng() % 3) {
        case 0: bytes[at] = static_cast<char>(rng()); break;
        case 1: bytes.erase(at, 1 + rng() % 8); break;
        default: bytes = bytes.substr(0, at) + "0123456789 -\n/"[rng() % 15] + bytes.substr(at); break;
      }
      if (bytes.empty()) bytes.push_back('v');
    }
    try {
      const TriangleMesh m = round % 3 == 2 ? parse_obj(bytes, "m.obj") : parse_ply(bytes, "m.ply");
      for (const auto& t : m.triangles) REQUIRE(std::max({t.x, t.y, t.z}) < m.positions.size());
      ++loaded;
    } catch (const InputError& err) {
      REQUIRE(std::string(err.what()).find('\n') == std::string::npos);
      ++rejected;
    }
  }
  MESSAGE("mutations: " << loaded << " loaded, " << rejected << " rejected");
  CHECK(loaded > 0);
  CHECK(rejected > 0);
}

TEST_CASE("triangle_mesh: the InfiniCube car.ply (shared test data)") {
  const std::string dir = icube::test::test_data_dir();
  if (dir.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  const TriangleMesh m = load_mesh(dir + "/meshes/car.ply");
  CHECK(m.positions.size() == 12564);
  CHECK(m.triangles.size() == 17105);  // every face of car.ply is a triangle
  const MeshBounds b = mesh_bounds(m);
  const glm::dvec3 ext = b.max - b.min;
  MESSAGE("car.ply: " << m.positions.size() << " vertices, " << m.triangles.size() << " triangles, extent " << ext.x
                      << " x " << ext.y << " x " << ext.z << " m");
  CHECK(ext.x == doctest::Approx(3.80).epsilon(0.01));
  CHECK(ext.y == doctest::Approx(1.84).epsilon(0.01));
  CHECK(ext.z == doctest::Approx(1.49).epsilon(0.01));
}
