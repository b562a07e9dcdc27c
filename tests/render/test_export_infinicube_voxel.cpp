// tools/export_infinicube_voxel.py, the part that runs without torch and fVDB
// (--arrays): the .icw parser and the arrays it would hand to fVDB, against a
// C++ brute force of InfiniCube's transform_grid_and_semantic(subdivide=True)
// (8 sub-voxels per voxel, transformed, re-voxelised at 0.2 m / origin 0.1,
// class of the nearest transformed voxel centre); bad inputs exit 1 naming the
// file and leave no output. Needs python3 with numpy (tools/install-deps.sh);
// without it the case skips with a message, or fails under ICUBE_REQUIRE_DATA=1.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "world/npy.h"
#include "world/voxel_grid.h"
#include "world/world_file.h"

#include <glm/gtc/matrix_transform.hpp>

#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <vector>

using namespace icube;

namespace {

void write_matrix(const std::string& path, const glm::dmat4& m) {
  std::vector<double> v;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) v.push_back(m[c][r]);
  world::write_npy(path, world::NpyArray::make<double>({4, 4}, v));
}

using Ijk = std::tuple<int, int, int>;

// C++ brute force of the re-voxelisation.
std::map<Ijk, int64_t> expected(const world::VoxelGrid& g, const glm::dmat4& m) {
  std::vector<std::pair<glm::dvec3, int64_t>> centres;
  g.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    centres.emplace_back(glm::dvec3(m * glm::dvec4(g.ijk_to_world(ijk), 1.0)), v.class_id);
  });
  std::set<Ijk> cells;
  g.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel&) {
    const glm::dvec3 c = g.ijk_to_world(ijk);
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 off{k & 1 ? 0.05 : -0.05, k & 2 ? 0.05 : -0.05, k & 4 ? 0.05 : -0.05};
      const glm::dvec3 p = glm::dvec3(m * glm::dvec4(c + off, 1.0));
      const glm::dvec3 f = glm::floor((p - 0.1) / 0.2 + 0.5);
      cells.insert({int(f.x), int(f.y), int(f.z)});
    }
  });
  std::map<Ijk, int64_t> out;
  for (const Ijk& c : cells) {
    const glm::dvec3 q = glm::dvec3(std::get<0>(c), std::get<1>(c), std::get<2>(c)) * 0.2 + 0.1;
    double best = 1e30;
    int64_t cls = -1;
    for (const auto& [p, k] : centres) {
      const double d = glm::dot(p - q, p - q);
      if (d < best) {
        best = d;
        cls = k;
      }
    }
    out[c] = cls;
  }
  return out;
}

std::map<Ijk, int64_t> exported(const std::string& dir) {
  const world::NpyArray ijk = world::read_npy(dir + "/ijk.npy");
  const world::NpyArray sem = world::read_npy(dir + "/semantics.npy");
  REQUIRE(ijk.dtype == world::NpyDtype::I4);
  REQUIRE(sem.dtype == world::NpyDtype::I8);
  REQUIRE(ijk.shape.size() == 2);
  REQUIRE(ijk.shape[1] == 3);
  REQUIRE(sem.shape == std::vector<uint64_t>{ijk.shape[0]});
  const std::vector<int32_t> v = ijk.values<int32_t>();
  const std::vector<int64_t> s = sem.values<int64_t>();
  std::map<Ijk, int64_t> out;
  for (size_t i = 0; i < s.size(); ++i) out[{v[3 * i], v[3 * i + 1], v[3 * i + 2]}] = s[i];
  CHECK(out.size() == s.size());  // no duplicate voxel
  return out;
}

}  // namespace

TEST_CASE("export_infinicube_voxel: .icw to the voxel-world arrays InfiniCube hands to fVDB") {
  const std::string py = test::python_with("numpy");
  if (py.empty()) {
    const char* req = std::getenv("ICUBE_REQUIRE_DATA");
    if (req && std::string(req) == "1") FAIL("python3 with numpy is missing (tools/install-deps.sh installs python3-numpy)");
    MESSAGE("skipped: no python3 with numpy (apt install python3-numpy)");
    return;
  }
  const std::string tool = std::string(ICUBE_SOURCE_DIR) + "/tools/export_infinicube_voxel.py";
  test::TempDir tmp("export-arrays");
  const std::string dir = tmp.path.string();
  // A blob of voxels with several classes, two bricks apart, at an origin off the 0.1 m lattice.
  world::VoxelGrid g({3.31, -1.73, 0.25}, 0.2);
  for (int i = -3; i < 4; ++i)
    for (int j = 0; j < 5; ++j)
      for (int k = 0; k < 3; ++k)
        if ((i + j + k) % 4 != 0) g.set({i, j, k}, static_cast<uint8_t>(1 + (i * 7 + j * 3 + k + 30) % 22), 5);
  g.set({20, 20, 1}, 9);
  world::save_world(g, dir + "/w.icw");

  SUBCASE("a pure translation onto the lattice keeps every voxel and class") {
    const glm::dmat4 m = glm::translate(glm::dmat4(1.0), -g.origin());
    write_matrix(dir + "/m.npy", m);
    const auto [rc, out] = test::run_shell(py + " " + tool + " " + dir + "/w.icw --world-to-voxel " + dir + "/m.npy --arrays " + dir + "/out");
    INFO(out);
    REQUIRE(rc == 0);
    const auto got = exported(dir + "/out");
    std::map<Ijk, int64_t> want;
    g.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) { want[{ijk.x, ijk.y, ijk.z}] = v.class_id; });
    CHECK(got == want);
    CHECK(got == expected(g, m));
  }
  SUBCASE("a rotated, shifted first camera: the brute force agrees voxel by voxel") {
    const glm::dmat4 m = glm::rotate(glm::translate(glm::dmat4(1.0), {-40.2, 7.9, -1.6}), 0.5236, glm::dvec3(0, 0, 1)) *
                         glm::rotate(glm::dmat4(1.0), 0.031, glm::dvec3(0, 1, 0));
    write_matrix(dir + "/m.npy", m);
    const auto [rc, out] = test::run_shell(py + " " + tool + " " + dir + "/w.icw --world-to-voxel " + dir + "/m.npy --arrays " + dir + "/out");
    INFO(out);
    REQUIRE(rc == 0);
    const auto got = exported(dir + "/out");
    const auto want = expected(g, m);
    CHECK(got.size() == want.size());
    size_t differ = 0;
    for (const auto& [ijk, cls] : want) {
      const auto it = got.find(ijk);
      if (it == got.end() || it->second != cls) {
        if (++differ <= 5)
          MESSAGE("voxel " << std::get<0>(ijk) << "," << std::get<1>(ijk) << "," << std::get<2>(ijk) << ": want class "
                           << cls << ", got " << (it == got.end() ? -1 : it->second));
      }
    }
    CHECK(differ == 0);
    MESSAGE(g.voxel_count() << " voxels -> " << got.size() << " after the rotation");
    CHECK(got.size() >= g.voxel_count());  // a rotated voxel's sub-voxels spread over neighbouring cells
  }
  SUBCASE("bad input exits 1 with a line naming the file, and writes nothing") {
    write_matrix(dir + "/m.npy", glm::dmat4(1.0));
    std::string bytes = scene::read_file(dir + "/w.icw");
    bytes[60] = static_cast<char>(bytes[60] ^ 0x40);
    scene::write_file_atomic(dir + "/bad.icw", bytes);
    auto [rc, out] = test::run_shell(py + " " + tool + " " + dir + "/bad.icw --world-to-voxel " + dir + "/m.npy --arrays " + dir + "/o1");
    CHECK(rc == 1);
    CHECK(out.find("bad.icw: byte") != std::string::npos);
    CHECK(out.find("CRC32") != std::string::npos);
    CHECK(!std::filesystem::exists(dir + "/o1"));
    write_matrix(dir + "/scale.npy", glm::scale(glm::dmat4(1.0), glm::dvec3(2.0)));
    std::tie(rc, out) = test::run_shell(py + " " + tool + " " + dir + "/w.icw --world-to-voxel " + dir + "/scale.npy --arrays " + dir + "/o2");
    CHECK(rc == 1);
    CHECK(out.find("scale.npy: not a rigid transform") != std::string::npos);
    CHECK(!std::filesystem::exists(dir + "/o2"));
    std::tie(rc, out) = test::run_shell(py + " " + tool + " " + dir + "/w.icw --clip " + dir + "/no-clip --arrays " + dir + "/o3");
    CHECK(rc == 1);
    CHECK(out.find("world_to_voxel_world.npy") != std::string::npos);
    scene::write_file_atomic(dir + "/pts.npy", "nope");
    std::tie(rc, out) = test::run_shell(py + " " + tool + " " + dir + "/pts.npy --world-to-voxel " + dir + "/m.npy --arrays " + dir + "/o4");
    CHECK(rc == 1);
    CHECK(out.find("pts.npy: not a readable .npy") != std::string::npos);
    std::tie(rc, out) = test::run_shell(py + " " + tool + " --help");
    CHECK(rc == 0);
    CHECK(out.find("voxel.pt") != std::string::npos);
  }
}
