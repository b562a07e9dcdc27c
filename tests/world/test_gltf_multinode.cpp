// A real multi-node GLB voxelises like the flat mesh it describes
// (engine/world/triangle_mesh.h parse_gltf, vehicle_mesh.h load_vehicle_mesh).
//
// The test writes the GLB with tinygltf: InfiniCube's car.ply (the built-in
// car when the shared data is absent) in glTF's axes (+y up, facing +z), cut
// into four parts placed by a node hierarchy: a root with translation,
// rotation and non-uniform centimetre scale; a child given as a matrix whose
// mesh has two primitives (uint32 indices); a grandchild with TRS and
// non-uniform scale; a mirrored sibling (negative scale, uint16 indices).
// Each part stores its vertices in its node's local frame (the inverse of
// the node's world transform, rounded to float as a file would have them).
// Checks: the loaded mesh is the flattened one (each local vertex times its
// world transform, composed here in double) in the object frame, winding
// flipped under the mirror; its extent is the car's; its voxels equal the
// flattened mesh's exactly and the car's within float rounding; a model
// without scenes (root nodes walked) loads the same; quantized positions
// (KHR_mesh_quantization: uint16, normalized int16) under a dequantizing node
// load as their dequantized values; and `icube world insert --mesh car.glb`
// writes exactly the flattened mesh's cells.
#include "world/car_mesh.h"
#include "world/mesh_voxelize.h"
#include "world/vehicle_mesh.h"
#include "world/voxel_grid.h"
#include "world/world_file.h"

#include "cli_test_util.h"
#include "gpu_test_context.h"
#include "scene/atomic_file.h"

#include "world/tinygltf_include.h"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include <cstring>
#include <set>
#include <tuple>
#include <sstream>

using namespace icube::world;
namespace fs = std::filesystem;

namespace {

// Object frame (x forward, y left, z up) -> glTF (x left, y up, z forward).
glm::dvec3 to_gltf(const glm::dvec3& p) { return {p.y, p.z, p.x}; }

struct Part {
  std::vector<glm::dvec3> positions;
  std::vector<uint32_t> indices;
};

// Four parts by triangle centroid along x (rear to front), each re-indexed.
std::vector<Part> split_along_x(const TriangleMesh& m) {
  const MeshBounds b = mesh_bounds(m);
  std::vector<Part> parts(4);
  std::vector<std::vector<int64_t>> remap(4, std::vector<int64_t>(m.positions.size(), -1));
  for (const auto& t : m.triangles) {
    const double cx = (m.positions[t.x].x + m.positions[t.y].x + m.positions[t.z].x) / 3.0;
    const size_t k = std::min<size_t>(3, static_cast<size_t>(4.0 * (cx - b.min.x) / (b.max.x - b.min.x)));
    for (int c = 0; c < 3; ++c) {
      int64_t& r = remap[k][t[c]];
      if (r < 0) {
        r = static_cast<int64_t>(parts[k].positions.size());
        parts[k].positions.push_back(m.positions[t[c]]);
      }
      parts[k].indices.push_back(static_cast<uint32_t>(r));
    }
  }
  return parts;
}

glm::dmat4 trs(const glm::dvec3& t, const glm::dvec3& axis, double angle, const glm::dvec3& s) {
  return glm::translate(glm::dmat4(1.0), t) * glm::rotate(glm::dmat4(1.0), angle, glm::normalize(axis)) *
         glm::scale(glm::dmat4(1.0), s);
}

struct Node {
  glm::dvec3 t, axis;
  double angle;
  glm::dvec3 s;
  glm::dmat4 local() const { return trs(t, axis, angle, s); }
  void write(tinygltf::Node& n) const {
    const glm::dquat q = glm::angleAxis(angle, glm::normalize(axis));
    n.translation = {t.x, t.y, t.z};
    n.rotation = {q.x, q.y, q.z, q.w};
    n.scale = {s.x, s.y, s.z};
  }
};

// The hierarchy: root N0 -> {N1 (matrix; mesh 0 = parts 0, 1) -> {N3 (mesh 2 = part 3)}, N2 (mirrored; mesh 1 = part
// 2)}.
const Node kRoot{{3.0, 0.5, -2.0}, {0.3, 1.0, 0.2}, 0.7, {0.01, 0.02, 0.01}};
const glm::dmat4 kBodyMatrix = trs({100.0, -20.0, 50.0}, {1, 0, 0}, glm::radians(90.0), {1.0, 1.0, 1.0});
const Node kMirrored{{-40.0, 10.0, 0.0}, {0, 0, 1}, 0.4, {-1.0, 2.0, 1.5}};
const Node kRear{{5.0, 5.0, 5.0}, {0, 1, 0}, 1.1, {2.0, 3.0, 0.5}};

struct GlbModel {
  std::string bytes;
  TriangleMesh flattened;  // object frame, in the reader's order (parts 0, 1, 3, 2)
};

class GlbWriter {
 public:
  // One primitive: positions (local, rounded to float) and indices; returns the local positions read back.
  tinygltf::Primitive primitive(const Part& p, const glm::dmat4& world, bool short_indices,
                                std::vector<glm::dvec3>& local) {
    const glm::dmat4 inv = glm::inverse(world);
    std::vector<float> xyz;
    glm::dvec3 lo(1e300), hi(-1e300);
    local.clear();
    for (const auto& v : p.positions) {
      const glm::vec3 f(glm::dvec3(inv * glm::dvec4(to_gltf(v), 1.0)));
      local.emplace_back(f);
      lo = glm::min(lo, glm::dvec3(f));
      hi = glm::max(hi, glm::dvec3(f));
      xyz.insert(xyz.end(), {f.x, f.y, f.z});
    }
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.attributes["POSITION"] = add(xyz.data(), xyz.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                                      p.positions.size(), {lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z});
    if (short_indices) {
      std::vector<uint16_t> idx(p.indices.begin(), p.indices.end());
      prim.indices = add(idx.data(), idx.size() * 2, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_SCALAR,
                         idx.size(), {}, {});
    } else {
      prim.indices = add(p.indices.data(), p.indices.size() * 4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                         TINYGLTF_TYPE_SCALAR, p.indices.size(), {}, {});
    }
    return prim;
  }

  tinygltf::Model model;

  int add(const void* data, size_t bytes, int component, int type, size_t count, std::vector<double> lo,
          std::vector<double> hi) {
    if (model.buffers.empty()) model.buffers.emplace_back();
    auto& buf = model.buffers[0].data;
    while (buf.size() % 4) buf.push_back(0);
    tinygltf::BufferView bv;
    bv.buffer = 0, bv.byteOffset = buf.size(), bv.byteLength = bytes;
    buf.insert(buf.end(), static_cast<const unsigned char*>(data), static_cast<const unsigned char*>(data) + bytes);
    model.bufferViews.push_back(bv);
    tinygltf::Accessor a;
    a.bufferView = static_cast<int>(model.bufferViews.size()) - 1, a.componentType = component, a.type = type;
    a.count = count, a.minValues = std::move(lo), a.maxValues = std::move(hi);
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size()) - 1;
  }
};

// Appends the part as the reader should give it: world * local, winding flipped under a mirror.
void flatten(const std::vector<glm::dvec3>& local, const Part& p, const glm::dmat4& world, TriangleMesh& out) {
  const uint32_t base = static_cast<uint32_t>(out.positions.size());
  for (const auto& l : local) out.positions.emplace_back(world * glm::dvec4(l, 1.0));
  const bool flip = glm::determinant(glm::dmat3(world)) < 0.0;
  for (size_t i = 0; i + 2 < p.indices.size(); i += 3)
    out.triangles.push_back(flip ? glm::uvec3(base + p.indices[i], base + p.indices[i + 2], base + p.indices[i + 1])
                                 : glm::uvec3(base + p.indices[i], base + p.indices[i + 1], base + p.indices[i + 2]));
}

GlbModel multinode_glb(const TriangleMesh& car, bool with_scene) {
  const std::vector<Part> parts = split_along_x(car);
  const glm::dmat4 w_body = kRoot.local() * kBodyMatrix, w_rear = w_body * kRear.local(),
                   w_mirrored = kRoot.local() * kMirrored.local();
  GlbWriter w;
  GlbModel out;
  std::vector<glm::dvec3> local[4];
  tinygltf::Mesh body, mirrored, rear;
  body.name = "body", mirrored.name = "front", rear.name = "rear";
  body.primitives = {w.primitive(parts[0], w_body, false, local[0]), w.primitive(parts[1], w_body, false, local[1])};
  mirrored.primitives = {w.primitive(parts[2], w_mirrored, true, local[2])};
  rear.primitives = {w.primitive(parts[3], w_rear, false, local[3])};
  w.model.meshes = {body, mirrored, rear};
  flatten(local[0], parts[0], w_body, out.flattened);
  flatten(local[1], parts[1], w_body, out.flattened);
  flatten(local[3], parts[3], w_rear, out.flattened);
  flatten(local[2], parts[2], w_mirrored, out.flattened);
  orient_mesh(out.flattened, default_mesh_axes(MeshFormat::Gltf));

  tinygltf::Node n0, n1, n2, n3;
  n0.name = "vehicle", n1.name = "body", n2.name = "front", n3.name = "rear";
  kRoot.write(n0);
  n0.children = {1, 2};
  n1.matrix.assign(&kBodyMatrix[0][0], &kBodyMatrix[0][0] + 16);  // column-major, as glTF
  n1.mesh = 0, n1.children = {3};
  kMirrored.write(n2);
  n2.mesh = 1;
  kRear.write(n3);
  n3.mesh = 2;
  w.model.nodes = {n0, n1, n2, n3};
  if (with_scene) {
    tinygltf::Scene s;
    s.nodes = {0};
    w.model.scenes = {s};
    w.model.defaultScene = 0;
  }
  w.model.asset.version = "2.0";
  std::ostringstream bytes;
  tinygltf::TinyGLTF writer;
  REQUIRE(writer.WriteGltfSceneToStream(&w.model, bytes, false, true));
  out.bytes = bytes.str();
  return out;
}

// The car in glTF axes as one primitive with integer positions (KHR_mesh_quantization):
// uint16 over [lo, hi] with a node T(lo) * S((hi - lo) / 65535), or normalized int16 with
// T(centre) * S(half extent). `flattened` gets the dequantized mesh in the object frame.
std::string quantized_glb(const TriangleMesh& car, bool normalized_short, TriangleMesh& flattened) {
  glm::dvec3 lo(1e300), hi(-1e300);
  for (const auto& p : car.positions) lo = glm::min(lo, to_gltf(p)), hi = glm::max(hi, to_gltf(p));
  const glm::dvec3 centre = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  const glm::dvec3 offset = normalized_short ? centre : lo, scale = normalized_short ? half : (hi - lo) / 65535.0;
  std::vector<uint16_t> q;
  flattened = {};
  for (const auto& p : car.positions) {
    const glm::dvec3 g = to_gltf(p);
    glm::dvec3 deq;
    for (int k = 0; k < 3; ++k) {
      if (normalized_short) {
        const auto v = static_cast<int16_t>(std::lround((g[k] - centre[k]) / half[k] * 32767.0));
        q.push_back(static_cast<uint16_t>(v));
        deq[k] = offset[k] + scale[k] * (v / 32767.0);
      } else {
        const auto v = static_cast<uint16_t>(std::lround((g[k] - lo[k]) / (hi[k] - lo[k]) * 65535.0));
        q.push_back(v);
        deq[k] = offset[k] + scale[k] * v;
      }
    }
    flattened.positions.push_back(deq);
  }
  flattened.triangles = car.triangles;
  orient_mesh(flattened, default_mesh_axes(MeshFormat::Gltf));

  GlbWriter w;
  std::vector<uint32_t> idx;
  for (const auto& t : car.triangles) idx.insert(idx.end(), {t.x, t.y, t.z});
  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  // 6 bytes per position padded to the 4-byte stride the extension requires.
  std::vector<unsigned char> packed;
  for (size_t i = 0; i < car.positions.size(); ++i) {
    const auto* e = reinterpret_cast<const unsigned char*>(&q[3 * i]);
    packed.insert(packed.end(), e, e + 6);
    packed.insert(packed.end(), {0, 0});
  }
  prim.attributes["POSITION"] =
      w.add(packed.data(), packed.size(),
            normalized_short ? TINYGLTF_COMPONENT_TYPE_SHORT : TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
            TINYGLTF_TYPE_VEC3, car.positions.size(), {}, {});
  w.model.accessors.back().normalized = normalized_short;
  w.model.bufferViews.back().byteStride = 8;
  prim.indices =
      w.add(idx.data(), idx.size() * 4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, idx.size(), {}, {});
  tinygltf::Mesh mesh;
  mesh.primitives = {prim};
  w.model.meshes = {mesh};
  tinygltf::Node n;
  n.mesh = 0, n.translation = {offset.x, offset.y, offset.z}, n.scale = {scale.x, scale.y, scale.z};
  w.model.nodes = {n};
  tinygltf::Scene sc;
  sc.nodes = {0};
  w.model.scenes = {sc};
  w.model.extensionsUsed = w.model.extensionsRequired = {"KHR_mesh_quantization"};
  w.model.asset.version = "2.0";
  std::ostringstream bytes;
  tinygltf::TinyGLTF writer;
  REQUIRE(writer.WriteGltfSceneToStream(&w.model, bytes, false, true));
  return bytes.str();
}

double max_distance(const TriangleMesh& a, const TriangleMesh& b) {
  double d = 0.0;
  for (size_t i = 0; i < a.positions.size() && i < b.positions.size(); ++i)
    d = std::max(d, glm::length(a.positions[i] - b.positions[i]));
  return d;
}

bool same_cells(const std::vector<VehicleVoxel>& a, const std::vector<VehicleVoxel>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].ijk != b[i].ijk || a[i].sub_voxels != b[i].sub_voxels) return false;
  return true;
}

// Cells in one list and not the other (by ijk and sub-voxel count); both sorted by ijk.
size_t cell_difference(const std::vector<VehicleVoxel>& a, const std::vector<VehicleVoxel>& b) {
  std::set<std::tuple<int, int, int, uint32_t>> sa, sb;
  for (const auto& c : a) sa.insert({c.ijk.x, c.ijk.y, c.ijk.z, c.sub_voxels});
  for (const auto& c : b) sb.insert({c.ijk.x, c.ijk.y, c.ijk.z, c.sub_voxels});
  size_t n = 0;
  for (const auto& k : sa) n += !sb.count(k);
  for (const auto& k : sb) n += !sa.count(k);
  return n;
}

TriangleMesh source_car() {
  const std::string dir = icube::test::test_data_dir();
  if (!dir.empty()) return load_mesh(dir + "/meshes/car.ply");
  MESSAGE("test data not found; using the built-in car for the multi-node GLB");
  return builtin_car_mesh();
}

icube::scene::BoxState test_box() {
  icube::scene::BoxState b;
  b.center = {10.05, -3.3, 0.8}, b.length = 4.6, b.width = 2.0, b.height = 1.6, b.heading = 0.4, b.valid = true;
  return b;
}

}  // namespace

TEST_CASE("gltf multi-node: a GLB of node-placed parts loads and voxelises as the flat car") {
  const TriangleMesh car = source_car();
  icube::test::TempDir dir("gltf-multinode");
  for (bool with_scene : {true, false}) {
    CAPTURE(with_scene);
    const GlbModel glb = multinode_glb(car, with_scene);
    const std::string path = (dir.path / "car.glb").string();
    icube::scene::write_file_atomic(path, glb.bytes);

    const VehicleMeshFile f = load_vehicle_mesh(path);
    CHECK(f.format == MeshFormat::Gltf);
    CHECK(f.axes == default_mesh_axes(MeshFormat::Gltf));
    REQUIRE(f.mesh.positions.size() == glb.flattened.positions.size());
    CHECK(f.mesh.triangles.size() == car.triangles.size());
    CHECK(max_distance(f.mesh, glb.flattened) < 1e-9);
    CHECK(f.mesh.triangles == glb.flattened.triangles);

    // The extent is the car's (float rounding of the stored local vertices only).
    const MeshBounds want = mesh_bounds(car), got = mesh_bounds(f.mesh);
    MESSAGE("GLB extent " << (got.max - got.min).x << " x " << (got.max - got.min).y << " x " << (got.max - got.min).z
                          << " m; car " << (want.max - want.min).x << " x " << (want.max - want.min).y << " x "
                          << (want.max - want.min).z);
    CHECK(glm::length(got.min - want.min) < 1e-5);
    CHECK(glm::length(got.max - want.max) < 1e-5);
    const MeshBounds fitted = mesh_bounds(fit_mesh_to_box(f.mesh, 4.6, 2.0, 1.6));
    CHECK(glm::length(fitted.min - glm::dvec3(-2.3, -1.0, -0.8)) < 1e-9);
    CHECK(glm::length(fitted.max - glm::dvec3(2.3, 1.0, 0.8)) < 1e-9);

    const auto cells = voxelize_vehicle(f.mesh, test_box(), 1);
    CHECK(cells.size() > 500);
    CHECK(same_cells(cells, voxelize_vehicle(glb.flattened, test_box(), 1)));
    const auto car_cells = voxelize_vehicle(car, test_box(), 1);
    const size_t diff = cell_difference(cells, car_cells);
    MESSAGE(cells.size() << " cells from the GLB, " << car_cells.size() << " from the flat car, " << diff
                         << " differ (float rounding of the stored vertices)");
    CHECK(diff * 200 <= car_cells.size());

    // Read without the y-up to z-up change, the car would lie on its side: height along y.
    const MeshBounds raw = mesh_bounds(load_mesh(path));
    CHECK((raw.max - raw.min).y == doctest::Approx((want.max - want.min).z).epsilon(1e-4));
  }
}

TEST_CASE("gltf multi-node: quantized positions (uint16, normalized int16) under a dequantizing node") {
  const TriangleMesh car = source_car();
  icube::test::TempDir dir("gltf-quantized");
  for (bool normalized : {false, true}) {
    CAPTURE(normalized);
    TriangleMesh want;
    const std::string path = (dir.path / "q.glb").string();
    icube::scene::write_file_atomic(path, quantized_glb(car, normalized, want));
    const VehicleMeshFile f = load_vehicle_mesh(path);
    REQUIRE(f.mesh.positions.size() == want.positions.size());
    CHECK(max_distance(f.mesh, want) < 1e-9);
    CHECK(max_distance(f.mesh, car) < 1e-4);  // 16-bit steps over a 4 m car: 0.06 mm
    CHECK(same_cells(voxelize_vehicle(f.mesh, test_box(), 1), voxelize_vehicle(want, test_box(), 1)));
  }
}

TEST_CASE("gltf multi-node: icube world insert --mesh car.glb writes the flat mesh's cells") {
  if (!fs::exists(icube::test::icube_binary())) {
    MESSAGE("skipped: " << icube::test::icube_binary().string() << " not built (cmake --build ... --target icube)");
    return;
  }
  icube::test::TempDir dir("cli-gltf-multinode");
  const GlbModel glb = multinode_glb(source_car(), true);
  const fs::path mesh = dir.path / "car.glb", world = dir.path / "empty.icw", out = dir.path / "out.icw";
  icube::scene::write_file_atomic(mesh.string(), glb.bytes);
  save_world(VoxelGrid(), world.string());
  const auto r = icube::test::run_icube("world insert '" + world.string() + "' --mesh '" + mesh.string() +
                                            "' --box 10.05,-3.3,0.8,4.6,2.0,1.6,0.4 -o '" + out.string() + "'",
                                        dir.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("(glTF, axes +z,+y,") != std::string::npos);
  const VoxelGrid g = load_world(out.string());
  const auto want = voxelize_vehicle(glb.flattened, test_box(), 1);
  CHECK(g.voxel_count() == want.size());
  size_t same = 0;
  for (const auto& c : want) {
    const Voxel v = g.get(c.ijk);
    same += v.class_id == static_cast<uint8_t>(SemanticClass::Car) && v.instance == 1;
  }
  CHECK(same == want.size());
}
