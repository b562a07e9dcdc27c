// Stage 3 lifting (engine/lift): the face-cell accumulation and the Gaussians
// it emits on hand-made samples (cells, integer means, per-cell patterns,
// faces, hidden surface voxels, interior voxels, order independence), the sky
// panorama fit, and `icube lift` end to end on the demo town: outputs, held-out
// PSNR, identical bytes on a re-run, bad input refused with nothing written.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "lift_demo_frames.h"
#include "lift/lift_frames.h"
#include "lift/sky_fit.h"
#include "lift/static_lift.h"
#include "scene/atomic_file.h"
#include "scene/png_read.h"
#include "splat/splat_scene.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

using namespace icube;
namespace fs = std::filesystem;

namespace {

constexpr double kVs = 0.2;

lift::ColorSample sample(glm::ivec3 ijk, int normal, glm::dvec3 local, uint8_t r, uint8_t g, uint8_t b) {
  lift::ColorSample s;
  s.ijk = ijk;
  s.normal = normal;
  s.point = (glm::dvec3(ijk) + local) * kVs;
  s.r = r, s.g = g, s.b = b;
  return s;
}

glm::vec3 dc_rgb(const splat::GaussianCloud& c, size_t i) {
  return glm::vec3(c.sh[3 * i], c.sh[3 * i + 1], c.sh[3 * i + 2]) * float(splat::kShC0) + glm::vec3(0.5f);
}

}  // namespace

TEST_CASE("lift: face slots and axes follow the ray caster's normals") {
  CHECK(lift::face_slot(-1) == 0);
  CHECK(lift::face_slot(1) == 1);
  CHECK(lift::face_slot(-2) == 2);
  CHECK(lift::face_slot(3) == 5);
  CHECK_THROWS(lift::face_slot(0));
  CHECK(lift::face_axes(0) == glm::ivec3(1, 2, 0));
  CHECK(lift::face_axes(3) == glm::ivec3(2, 0, 1));
  CHECK(lift::face_axes(5) == glm::ivec3(0, 1, 2));
}

TEST_CASE("lift: samples colour the 0.1 m cells of the faces they hit; Gaussians on the face plane") {
  world::VoxelGrid g(glm::dvec3(0.0), kVs);
  // A 3 x 1 x 1 bar of class 4 on top of a 3 x 3 x 1 slab of class 2 (the slab's centre is interior
  // only if covered on every side: it is not, the slab is one voxel thick).
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y) g.set({x, y, 0}, 2, 0);
  for (int x = 0; x < 3; ++x) g.set({x, 1, 1}, 4, 0);
  lift::StaticLiftAccumulator acc(g);
  // The top (+z) face of voxel (0, 0, 0): cell (u=x, v=y) = (0, 0) twice, (1, 1) once.
  acc.add(sample({0, 0, 0}, 3, {0.2, 0.3, 1.0}, 10, 20, 30));
  acc.add(sample({0, 0, 0}, 3, {0.1, 0.1, 1.0}, 11, 21, 31));
  acc.add(sample({0, 0, 0}, 3, {0.7, 0.9, 1.0}, 200, 100, 50));
  // The −x face of the bar's first voxel: (u=y, v=z) cell (1, 0).
  acc.add(sample({0, 1, 1}, -1, {0.0, 0.6, 0.2}, 255, 0, 0));
  CHECK(acc.samples() == 4);
  CHECK(acc.faces() == 2);

  lift::LiftOptions o;
  o.hidden = false;
  lift::LiftStats st;
  const splat::GaussianCloud one = lift::emit_static_gaussians(g, acc, o, &st);
  REQUIRE(one.size() == 3);
  CHECK(st.seen_faces == 2);
  CHECK(st.seen_cells == 3);
  // Output order: voxel (0,0,0) first (z, y, x), its cells row-major.
  CHECK(one.positions[0].x == doctest::Approx(0.05));
  CHECK(one.positions[0].y == doctest::Approx(0.05));
  CHECK(one.positions[0].z == doctest::Approx(0.2));  // the top face plane
  const glm::vec3 c0 = dc_rgb(one, 0);
  CHECK(c0.r * 255.0f == doctest::Approx(10.5f).epsilon(1e-5));  // the integer mean of 10 and 11
  CHECK(c0.b * 255.0f == doctest::Approx(30.5f).epsilon(1e-5));
  CHECK(one.positions[1].x == doctest::Approx(0.15));
  CHECK(one.positions[1].y == doctest::Approx(0.15));
  CHECK(dc_rgb(one, 1).r * 255.0f == doctest::Approx(200.0f).epsilon(1e-5));
  // Flat on the face: thin along z, kCellSigma · 0.1 m along x and y.
  CHECK(one.scales[0].z == doctest::Approx(lift::kNormalSigma));
  CHECK(one.scales[0].x == doctest::Approx(double(lift::kCellSigma) * 0.1));
  // The bar's −x face at x = 0, cell (y, z) = (1, 0): y in [0.3, 0.4), z in [0.2, 0.3).
  CHECK(one.positions[2].x == doctest::Approx(0.0));
  CHECK(one.positions[2].y == doctest::Approx(0.35));
  CHECK(one.positions[2].z == doctest::Approx(0.25));
  CHECK(one.scales[2].x == doctest::Approx(lift::kNormalSigma));
  CHECK(one.opacities[2] == doctest::Approx(lift::kSurfaceOpacity));

  SUBCASE("four per cell on a 2 x 2 pattern, σ halved, each in its 0.05 m quarter's colour") {
    o.per_cell = 4;
    const splat::GaussianCloud four = lift::emit_static_gaussians(g, acc, o);
    REQUIRE(four.size() == 12);
    CHECK(four.positions[0].x == doctest::Approx(0.025));
    CHECK(four.positions[3].y == doctest::Approx(0.075));
    CHECK(four.scales[0].x == doctest::Approx(double(lift::kCellSigma) * 0.05));
    // Cell (0, 0): the sample at (0.1, 0.1) is quarter (0, 0), the one at (0.2, 0.3) quarter (0, 1);
    // the two quarters without samples take the cell's mean.
    CHECK(dc_rgb(four, 0).r * 255.0f == doctest::Approx(11.0f).epsilon(1e-5));
    CHECK(dc_rgb(four, 1).r * 255.0f == doctest::Approx(10.5f).epsilon(1e-5));
    CHECK(dc_rgb(four, 2).r * 255.0f == doctest::Approx(10.0f).epsilon(1e-5));
    CHECK(dc_rgb(four, 3).r * 255.0f == doctest::Approx(10.5f).epsilon(1e-5));
  }
  SUBCASE("one per face: the sample-weighted mean colour at the face centre") {
    o.face_gaussians = true;
    const splat::GaussianCloud face = lift::emit_static_gaussians(g, acc, o);
    REQUIRE(face.size() == 2);
    CHECK(face.positions[0].x == doctest::Approx(0.1));
    CHECK(dc_rgb(face, 0).r * 255.0f == doctest::Approx((10.0f + 11.0f + 200.0f) / 3.0f).epsilon(1e-5));
  }
  SUBCASE("hidden surface voxels: one Gaussian each in their class's mean colour, grey when unseen") {
    o.hidden = true;
    const splat::GaussianCloud h = lift::emit_static_gaussians(g, acc, o, &st);
    // 9 slab + 3 bar voxels, all exposed; 2 seen.
    CHECK(st.hidden_voxels == 10);
    REQUIRE(h.size() == 13);
    // The first hidden voxel in z, y, x order is (1, 0, 0), class 2: the slab's mean cell colour.
    CHECK(glm::length(h.positions[3] - glm::dvec3(0.3, 0.1, 0.1)) < 1e-12);
    CHECK(dc_rgb(h, 3).r * 255.0f == doctest::Approx((10.5f + 200.0f) / 2.0f).epsilon(1e-4));
    CHECK(h.scales[3].x == doctest::Approx(0.4 * kVs));
    CHECK(h.opacities[3] == doctest::Approx(lift::kHiddenOpacity));
    // The bar's unseen voxels (class 4: one seen cell, pure red).
    CHECK(dc_rgb(h, 12).r == doctest::Approx(1.0f));
  }
}

TEST_CASE("lift: an interior voxel gets no Gaussian; the result does not depend on the sample order") {
  world::VoxelGrid g(glm::dvec3(100000.0, -5000.0, 10.0), kVs);
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      for (int z = 0; z < 3; ++z) g.set({x, y, z}, 7, 0);
  std::vector<lift::ColorSample> samples;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 6000; ++i) {
    const int normal = int(rng() % 3 + 1) * (rng() % 2 ? 1 : -1);
    const int axis = std::abs(normal) - 1;
    glm::ivec3 ijk(int(rng() % 3), int(rng() % 3), int(rng() % 3));
    ijk[axis] = normal > 0 ? 2 : 0;
    glm::dvec3 local(u(rng), u(rng), u(rng));
    local[axis] = normal > 0 ? 1.0 : 0.0;
    lift::ColorSample s;
    s.ijk = ijk;
    s.normal = normal;
    s.point = g.origin() + (glm::dvec3(ijk) + local) * kVs;
    s.r = uint8_t(rng()), s.g = uint8_t(rng()), s.b = uint8_t(rng());
    samples.push_back(s);
  }
  auto emit = [&](const std::vector<lift::ColorSample>& ss) {
    lift::StaticLiftAccumulator acc(g);
    for (const auto& s : ss) acc.add(s);
    return splat::gaussians_to_ply_bytes(lift::emit_static_gaussians(g, acc, lift::LiftOptions{}));
  };
  const std::string a = emit(samples);
  std::shuffle(samples.begin(), samples.end(), rng);
  CHECK(a == emit(samples));
  lift::StaticLiftAccumulator acc(g);
  for (const auto& s : samples) acc.add(s);
  lift::LiftStats st;
  const splat::GaussianCloud c = lift::emit_static_gaussians(g, acc, lift::LiftOptions{}, &st);
  CHECK(st.seen_faces == 54);     // every outer face of the 3³ cube
  CHECK(st.seen_cells == 216);    // 4 cells each
  CHECK(st.hidden_voxels == 0);   // every exposed voxel is seen; the centre voxel is interior
  CHECK(c.size() == 216);
  for (const auto& p : c.positions) CHECK(glm::length(p - g.ijk_to_world({1, 1, 1})) > 0.25);
}

TEST_CASE("lift: the sky panorama: directions land in their equirect texels, holes filled by rows") {
  lift::SkyFitter f(8, 4);
  // Straight up: row 0; along +x at the horizon: row 2 (θ = π/2 → t = 2), column 4 (s = 0.5·8).
  f.add(glm::dvec3(0.0, 0.0, 1.0), 10, 20, 30);
  f.add(glm::dvec3(1.0, 0.0, 0.0), 100, 150, 200);
  f.add(glm::dvec3(1.0, 0.0, 0.0), 102, 150, 200);
  const splat::SkyImage img = f.image();
  REQUIRE(img.width == 8);
  REQUIRE(img.rgba.size() == 8 * 4 * 4);
  auto at = [&](uint32_t x, uint32_t y, int c) { return int(img.rgba[(size_t(y) * 8 + x) * 4 + size_t(c)]); };
  CHECK(at(4, 2, 0) == 101);
  CHECK(at(0, 2, 1) == 150);  // the row's mean where its texels saw nothing
  CHECK(at(3, 0, 2) == 30);
  CHECK(at(5, 1, 0) == 10);   // row 1: nearest filled row, the upper one on a tie
  CHECK(at(5, 3, 0) == 101);  // row 3: row 2
  CHECK(at(0, 0, 3) == 255);
  // The evaluation with the renderer's own lookup gives the texel colour back.
  const splat::SkyModel sky = splat::sky_equirect(std::make_shared<const splat::SkyImage>(img));
  // At the centre of row 2 (θ = 0.625π) every texel of the row is (101, 150, 200).
  const double th = 0.625 * 3.14159265358979, la = -3.14159265358979 / 8.0;
  const glm::vec3 d(float(std::sin(th) * std::cos(la)), float(std::sin(th) * std::sin(la)), float(std::cos(th)));
  const glm::vec3 c = splat::sky_color(sky, glm::vec3(0.0f), d);
  CHECK(c.g * 255.0f == doctest::Approx(150.0f).epsilon(1e-3));
  CHECK(c.r * 255.0f == doctest::Approx(101.0f).epsilon(1e-3));
}

TEST_CASE("cli: icube lift on the demo town: outputs, held-out PSNR, identical bytes twice, bad input refused" *
          doctest::test_suite("slow-gpu")) {
  const test::LiftDemoFrames& demo = test::lift_demo_frames();
  const test::TempDir& dir = demo.dir;
  const std::string &scene = demo.scene, &world = demo.world;
  const fs::path& frames = demo.frames;
  const fs::path out = dir.path / "lifted", out2 = dir.path / "lifted2";
  const std::string args = "lift '" + world + "' '" + frames.string() + "' --scene '" + scene + "' --key-every 2 ";
  const test::CliRun r = test::run_icube(args + "-o '" + out.string() + "'", dir.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  for (const char* f : {"gaussians_static.ply", "sky.png", "scene.json", "lift_report.json", "eval.png"})
    CHECK(fs::is_regular_file(out / f));
  const auto rep = nlohmann::json::parse(scene::read_file((out / "lift_report.json").string()));
  MESSAGE("demo lift: " << rep["gaussians"].dump() << ", held-out " << rep["held_out"].dump());
  CHECK(rep["key_frames"].size() == 4);  // frames 0, 2, 4, 6 of the 8 (20:36:2)
  CHECK(rep["held_out"].size() == 4);
  // The bar: the Gaussians' held-out frame must be closer to the reference than the previous key
  // frame's image is (the stale-view baseline: what a viewer without novel views would show), over
  // the same static pixels; and above 18 dB (measured 20.9-21.8 dB at this 208 x 120 camera, 23.4 dB
  // at 832 x 480 over frames 20:60:2).
  for (const auto& h : rep["held_out"]) {
    const size_t f = h["frame"].get<size_t>();
    const std::string name = render::frame_file_name(f), prev = render::frame_file_name(f - 1);
    const scene::Image8 ref = scene::read_png((frames / "rgb" / name).string(), 3);
    const scene::Image8 key = scene::read_png((frames / "rgb" / prev).string(), 3);
    int w = 0, hh = 0;
    const std::vector<uint16_t> inst = scene::decode_png_gray16(
        scene::read_file((frames / "instance" / name).string()), name, &w, &hh);
    double se = 0.0;
    size_t n = 0;
    for (size_t p = 0; p < inst.size(); ++p) {
      if (inst[p] >= lift::kDynamicInstanceMin) continue;
      for (size_t c = 0; c < 3; ++c) {
        const double d = (double(ref.pixels[3 * p + c]) - double(key.pixels[3 * p + c])) / 255.0;
        se += d * d;
      }
      ++n;
    }
    const double baseline = lift::psnr_from_mse(se / (3.0 * double(n)));
    CAPTURE(f);
    CHECK(h["psnr_db"].get<double>() >= 18.0);
    CHECK(h["psnr_db"].get<double>() > baseline + 1.0);
    MESSAGE("held-out frame " << f << ": Gaussians " << h["psnr_db"].get<double>() << " dB, previous key frame "
                              << baseline << " dB");
  }
  const splat::SplatScene sc = splat::read_splat_scene((out / "scene.json").string());
  CHECK(sc.static_set.size() == rep["gaussians"]["total"].get<size_t>());
  const scene::Image8 sky = scene::read_png((out / "sky.png").string(), 4);
  CHECK(sky.width == 256);
  CHECK(sky.height == 128);
  // Same inputs, same bytes.
  REQUIRE(test::run_icube(args + "-o '" + out2.string() + "'", dir.path).code == 0);
  CHECK(scene::read_file((out / "gaussians_static.ply").string()) ==
        scene::read_file((out2 / "gaussians_static.ply").string()));
  CHECK(scene::read_file((out / "sky.png").string()) == scene::read_file((out2 / "sky.png").string()));

  // A frames folder whose meta lost its poses, and one missing a PNG: one-line errors, nothing written.
  const fs::path bad = dir.path / "bad", none = dir.path / "none";
  fs::create_directories(bad);
  fs::copy(frames, bad, fs::copy_options::recursive);
  auto meta = nlohmann::json::parse(scene::read_file((bad / "frames_meta.json").string()));
  meta["poses"].erase(meta["poses"].size() - 1);
  scene::write_file_atomic((bad / "frames_meta.json").string(), meta.dump());
  test::CliRun e = test::run_icube("lift '" + world + "' '" + bad.string() + "' -o '" + none.string() + "'", dir.path);
  CHECK(e.code != 0);
  CHECK(e.output.find("frames_meta.json: /poses: needs one 4x4 pose per frame") != std::string::npos);
  CHECK_FALSE(fs::exists(none));
  fs::copy_file(frames / "frames_meta.json", bad / "frames_meta.json", fs::copy_options::overwrite_existing);
  fs::remove(bad / "instance" / "000003.png");
  e = test::run_icube("lift '" + world + "' '" + bad.string() + "' -o '" + none.string() + "'", dir.path);
  CHECK(e.code != 0);
  CHECK(e.output.find("000003.png is missing") != std::string::npos);
  CHECK_FALSE(fs::exists(none));
}
