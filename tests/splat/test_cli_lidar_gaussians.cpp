// `icube lidar --gaussians` end to end (tools/cmd_lidar.cpp): the `icube`
// binary next to icube-tests casts a small generated 3DGS .ply (a wall of
// flat Gaussians 8 m ahead of the sensor) along a two-pose --trajectory .npy;
// checks the output tree (lidar.json, poses.npy, ply/, bin/, range/,
// range_color/ per frame), that PLY, KITTI .bin and the range PNG agree on the
// returns, and that the ranges are the wall's (x = 8 m, then 7 m after the
// sensor moved 1 m forward). Bad input (a garbage .ply, an out-of-range
// option): a one-line error naming the file or option, a non-zero exit and no
// output folder (nor staging folder) left behind. Skips with a message when
// the `icube` binary was not built.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "test_stb_image.h"

#include "render/lidar/lidar_io.h"
#include "scene/atomic_file.h"
#include "splat/gaussians.h"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace icube;
using test::icube_binary;
using test::TempDir;
using Run = test::CliRun;
namespace fs = std::filesystem;

namespace {

Run run(const std::string& args, const fs::path& dir) { return test::run_icube(args, dir); }

// A 12 × 6 m wall at x = 8 m: flat Gaussians (2 cm thick, 0.5 m wide), opaque, grey.
splat::GaussianCloud wall() {
  splat::GaussianCloud c;
  c.sh_degree = 0;
  const float dc[3] = {0.5f, 0.5f, 0.5f};
  for (double y = -6.0; y <= 6.0; y += 0.4)
    for (double z = -1.5; z <= 4.5; z += 0.4) c.add({8.0, y, z}, glm::vec3(0.02f, 0.5f, 0.5f), {1, 0, 0, 0}, 0.95f, dc);
  return c;
}

std::string poses_npy(const std::vector<double>& xs) {
  std::vector<glm::dmat4> m;
  for (const double x : xs) {
    glm::dmat4 p(1.0);
    p[3] = glm::dvec4(x, 0.0, 1.5, 1.0);
    m.push_back(p);
  }
  return render::lidar_poses_npy(m);
}

std::vector<uint16_t> read_png16(const std::string& path, int& w, int& h) {
  const std::string png = scene::read_file(path);
  int c = 0;
  stbi_us* px = stbi_load_16_from_memory(reinterpret_cast<const stbi_uc*>(png.data()), static_cast<int>(png.size()),
                                         &w, &h, &c, 1);
  std::vector<uint16_t> out;
  if (px) out.assign(px, px + size_t(w) * size_t(h));
  stbi_image_free(px);
  return out;
}

bool staging_left(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".partial-") != std::string::npos) return true;
  return false;
}

}  // namespace

TEST_CASE("cli: icube lidar --gaussians writes plausible PLY, KITTI .bin and range PNGs, and fails cleanly on bad input") {
  if (!fs::exists(icube_binary())) {
    MESSAGE("skipped: " << icube_binary().string() << " not built (cmake --build ... --target icube)");
    return;
  }
  TempDir t("cli-lidar-gs");
  const fs::path ply = t.path / "wall.ply", poses = t.path / "poses.npy", out = t.path / "out";
  splat::write_gaussians_ply(ply.string(), wall());
  scene::write_file_atomic(poses.string(), poses_npy({0.0, 1.0}));
  const uint32_t beams = 16, columns = 360;
  const std::string model = " --beams 16 --elevation -10:10 --columns 360 --range 0.5:50";

  SUBCASE("good input") {
    const Run r = run("lidar --gaussians '" + ply.string() + "' --trajectory '" + poses.string() + "'" + model +
                          " -o '" + out.string() + "'",
                      t.path);
    INFO(r.output);
    REQUIRE(r.code == 0);
    CHECK(fs::exists(out / "lidar.json"));
    CHECK(fs::exists(out / "poses.npy"));
    CHECK(!staging_left(t.path));
    for (int f = 0; f < 2; ++f) {
      CAPTURE(f);
      char name[16];
      std::snprintf(name, sizeof name, "%06d", f);
      const std::string stem = name;
      for (const char* sub : {"ply", "bin", "range", "range_color"})
        CHECK(fs::exists(out / sub / (stem + (std::string(sub) == "ply" ? ".ply" : std::string(sub) == "bin" ? ".bin" : ".png"))));
      const auto pts = render::parse_lidar_ply(scene::read_file((out / "ply" / (stem + ".ply")).string()), stem);
      const auto bin = render::parse_kitti_bin(scene::read_file((out / "bin" / (stem + ".bin")).string()), stem);
      CHECK(fs::file_size(out / "bin" / (stem + ".bin")) == 16 * bin.size());
      REQUIRE(pts.size() == bin.size());
      // The wall fills the front half of the field of view: with ±10° and a 12 × 6 m wall, a
      // good share of the 16 × 360 rays return.
      MESSAGE("frame " << f << ": " << pts.size() << " returns of " << beams * columns << " rays");
      CHECK(pts.size() > 200);
      CHECK(pts.size() < size_t{beams} * columns / 2);
      const double wall_x = 8.0 - f;  // sensor x = f
      size_t bad = 0;
      for (size_t i = 0; i < pts.size(); ++i) {
        const auto& p = pts[i];
        const double x = p.x, y = p.y, z = p.z;
        const double dist = std::sqrt(x * x + y * y + z * z);
        const bool ok = std::fabs(x - wall_x) < 0.1 && std::fabs(dist - double(p.range)) < 1e-3 * dist &&
                        p.x == bin[i][0] && p.y == bin[i][1] && p.z == bin[i][2] && p.intensity == bin[i][3] &&
                        p.intensity >= 0.0f && p.intensity <= 1.0f && p.ring < beams;
        if (!ok && bad++ < 5)
          MESSAGE("return " << i << ": (" << p.x << ", " << p.y << ", " << p.z << ") range " << p.range << " ring "
                            << p.ring << " intensity " << p.intensity);
      }
      CHECK(bad == 0);
      int w = 0, h = 0;
      const auto range = read_png16((out / "range" / (stem + ".png")).string(), w, h);
      CHECK(w == int(columns));
      CHECK(h == int(beams));
      size_t nonzero = 0, bad_px = 0;
      for (const uint16_t cm : range)
        if (cm != 0) {
          ++nonzero;
          // wall distance 8 − f m ahead, at most the distance to its far corner (y ±6.2, z up to 3.2 m
          // from the sensor at 1.5 m)
          const double far = std::sqrt(wall_x * wall_x + 6.2 * 6.2 + 3.2 * 3.2) + 0.1;
          if (cm < 100 * (wall_x - 0.1) || cm > 100 * far) ++bad_px;
        }
      CHECK(nonzero == pts.size());
      CHECK(bad_px == 0);
    }
  }

  SUBCASE("a garbage .ply: error naming the file, non-zero exit, no output") {
    const fs::path bad = t.path / "garbage.ply";
    {
      std::ofstream o(bad, std::ios::binary);
      o << "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nend_header\n\x01\x02";
    }
    const Run r = run("lidar --gaussians '" + bad.string() + "' --trajectory '" + poses.string() + "'" + model +
                          " -o '" + out.string() + "'",
                      t.path);
    INFO(r.output);
    CHECK(r.code != 0);
    CHECK(r.output.find("garbage.ply") != std::string::npos);
    CHECK(!fs::exists(out));
    CHECK(!staging_left(t.path));
  }

  SUBCASE("an out-of-range option: error naming it, non-zero exit, no output") {
    const Run r = run("lidar --gaussians '" + ply.string() + "' --trajectory '" + poses.string() + "'" + model +
                          " --alpha-threshold 2 -o '" + out.string() + "'",
                      t.path);
    INFO(r.output);
    CHECK(r.code != 0);
    CHECK(r.output.find("--alpha-threshold") != std::string::npos);
    CHECK(!fs::exists(out));
  }
}
