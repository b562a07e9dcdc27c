// Gaussian scenes with dynamic objects (engine/splat/splat_scene.h): placement
// against hand-computed poses (90° yaw + translation, 100 km away), Σ' = RΣRᵀ,
// exact SH rotation (colour at R·d of the placed Gaussian = colour at d of the
// original), the scene JSON (three pose forms, absent frames, relative paths,
// mixed SH degrees) and its one-line errors, and a rendered frame of a scene
// with a moving object against the hand-composed cloud (CPU reference and GPU).
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "splat/rasterizer_cpu.h"
#include "splat/rasterizer_gpu.h"
#include "splat/splat_format.h"
#include "splat/splat_scene.h"
#include "test_splat_util.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>
#include <unistd.h>

using namespace icube;

namespace {

namespace fs = std::filesystem;

glm::dmat4 yaw_pose(double yaw, const glm::dvec3& t) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  glm::dmat4 m(1.0);
  m[0] = {c, s, 0, 0};  // columns
  m[1] = {-s, c, 0, 0};
  m[3] = {t, 1.0};
  return m;
}

glm::dmat3 quat_matrix(const glm::dvec4& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  return glm::dmat3(1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y), 2 * (x * y - w * z),
                    1 - 2 * (x * x + z * z), 2 * (y * z + w * x), 2 * (x * z + w * y), 2 * (y * z - w * x),
                    1 - 2 * (x * x + y * y));
}

glm::dmat3 covariance_double(const glm::vec3& s, const glm::vec4& q) {
  const glm::dmat3 r = quat_matrix(glm::normalize(glm::dvec4(q)));
  const glm::dvec3 sd(s);
  return r * glm::dmat3(sd.x * sd.x, 0, 0, 0, sd.y * sd.y, 0, 0, 0, sd.z * sd.z) * glm::transpose(r);
}

fs::path scratch_dir(const char* name) {
  const auto d = fs::temp_directory_path() / (std::string(name) + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// The object of the rendering tests: a few axis-aligned (identity-rotation) SH1 Gaussians in the
// object frame, so the 90°-yaw placement can be written down by hand.
splat::GaussianCloud axis_aligned_car() {
  splat::GaussianCloud c;
  c.sh_degree = 1;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 40; ++i) {
    const glm::dvec3 p(2.0 * u(rng), 0.9 * u(rng), 0.7 * u(rng));
    const glm::vec3 s(float(0.05 + 0.2 * std::fabs(u(rng))), float(0.05 + 0.1 * std::fabs(u(rng))),
                      float(0.05 + 0.05 * std::fabs(u(rng))));
    float sh[12];
    for (int k = 0; k < 12; ++k) sh[k] = float((k < 3 ? 1.2 : 0.4) * u(rng));
    c.add(p, s, {1.0f, 0.0f, 0.0f, 0.0f}, float(0.5 + 0.45 * u(rng)), sh);
  }
  return c;
}

// The car placed by a 90° yaw and translation t, written out by hand: (x, y, z) -> (−y, x, z) + t,
// scales (a, b, c) -> (b, a, c) with identity rotation, SH1 (k1, k2, k3) = (−C1·y, C1·z, −C1·x)
// coefficients -> (k3, k2, −k1).
splat::GaussianCloud car_yaw90_by_hand(const splat::GaussianCloud& car, const glm::dvec3& t) {
  splat::GaussianCloud out;
  out.sh_degree = 1;
  for (size_t i = 0; i < car.size(); ++i) {
    const auto& p = car.positions[i];
    const auto& s = car.scales[i];
    const float* c = &car.sh[i * 12];
    float sh[12];
    for (int ch = 0; ch < 3; ++ch) {
      sh[ch] = c[ch];
      sh[3 + ch] = c[9 + ch];
      sh[6 + ch] = c[6 + ch];
      sh[9 + ch] = -c[3 + ch];
    }
    out.add(glm::dvec3(-p.y, p.x, p.z) + t, {s.y, s.x, s.z}, {1.0f, 0.0f, 0.0f, 0.0f}, car.opacities[i], sh);
  }
  return out;
}

splat::GaussianCloud translated_by_hand(const splat::GaussianCloud& car, const glm::dvec3& t) {
  auto out = car;
  for (auto& p : out.positions) p += t;
  return out;
}

splat::GaussianCloud concat(const splat::GaussianCloud& a, const splat::GaussianCloud& b) {
  auto out = a;
  splat::append_cloud(out, b);
  return out;
}

double max_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  double d = 0.0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, std::fabs(double(a[i]) - double(b[i])));
  return d;
}

}  // namespace

TEST_CASE("splat scene: placement against hand-computed poses (90° yaw + translation, 100 km away)") {
  splat::GaussianCloud one;
  one.sh_degree = 1;
  const float sh[12] = {0.1f, 0.2f, 0.3f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f, 8.0f, 9.0f};
  one.add({1.0, 2.0, 3.0}, {0.1f, 0.2f, 0.3f}, {1.0f, 0.0f, 0.0f, 0.0f}, 0.7f, sh);

  splat::GaussianCloud out;
  out.sh_degree = 1;
  splat::append_placed(out, one, yaw_pose(std::numbers::pi / 2, {10.0, -5.0, 2.0}));
  REQUIRE(out.size() == 1);
  CHECK(out.positions[0].x == doctest::Approx(-2.0 + 10.0).epsilon(1e-12));
  CHECK(out.positions[0].y == doctest::Approx(1.0 - 5.0).epsilon(1e-12));
  CHECK(out.positions[0].z == doctest::Approx(3.0 + 2.0).epsilon(1e-12));
  CHECK(bool(out.scales[0] == one.scales[0]));
  CHECK(out.opacities[0] == 0.7f);
  const float h = float(std::sqrt(0.5));
  CHECK(out.rotations[0].x == doctest::Approx(h));  // w
  CHECK(out.rotations[0].y == doctest::Approx(0.0).epsilon(1e-7));
  CHECK(out.rotations[0].z == doctest::Approx(0.0).epsilon(1e-7));
  CHECK(out.rotations[0].w == doctest::Approx(h));  // z
  const auto cov = splat::covariance3d(out.scales[0], out.rotations[0]);
  const double want_cov[6] = {0.04, 0.0, 0.0, 0.01, 0.0, 0.09};  // diag(b², a², c²)
  for (int k = 0; k < 6; ++k) CHECK(std::fabs(double(cov[size_t(k)]) - want_cov[k]) < 1e-7);
  const float want_sh[12] = {0.1f, 0.2f, 0.3f, 7.0f, 8.0f, 9.0f, 4.0f, 5.0f, 6.0f, -1.0f, -2.0f, -3.0f};
  for (int k = 0; k < 12; ++k) {
    CAPTURE(k);
    CHECK(out.sh[size_t(k)] == doctest::Approx(want_sh[k]).epsilon(1e-6));
  }

  // 100 km away with a 30° yaw: p' = R·p + t in double
  const double a = std::numbers::pi / 6, c = std::cos(a), s = std::sin(a);
  const glm::dvec3 t(100000.0, -200000.0, 30.0);
  splat::GaussianCloud far;
  far.sh_degree = 1;
  splat::append_placed(far, one, yaw_pose(a, t));
  CHECK(std::fabs(far.positions[0].x - (c * 1.0 - s * 2.0 + t.x)) < 1e-9);
  CHECK(std::fabs(far.positions[0].y - (s * 1.0 + c * 2.0 + t.y)) < 1e-9);
  CHECK(std::fabs(far.positions[0].z - (3.0 + t.z)) < 1e-9);
  CHECK(far.rotations[0].x == doctest::Approx(std::cos(a / 2)));
  CHECK(far.rotations[0].w == doctest::Approx(std::sin(a / 2)));

  // a pure translation leaves everything but the position untouched
  splat::GaussianCloud moved;
  moved.sh_degree = 1;
  splat::append_placed(moved, one, yaw_pose(0.0, {0.5, 0.25, -1.0}));
  CHECK(bool(moved.positions[0] == glm::dvec3(1.5, 2.25, 2.0)));
  CHECK(bool(moved.rotations[0] == one.rotations[0]));
  CHECK(moved.sh == one.sh);

  // non-rigid poses are refused
  glm::dmat4 scaled = yaw_pose(0.3, t);
  scaled[0] *= 1.01;
  CHECK(!splat::rigid_transform_error(scaled).empty());
  CHECK_THROWS_AS(splat::append_placed(moved, one, scaled), std::invalid_argument);
  glm::dmat4 mirror(1.0);
  mirror[2][2] = -1.0;
  CHECK(splat::rigid_transform_error(mirror).find("determinant") != std::string::npos);
  CHECK(splat::rigid_transform_error(yaw_pose(1.0, t)).empty());
}

TEST_CASE("splat scene: placed covariance is R·Σ·Rᵀ and SH colour at R·d equals the original at d (degrees 1-3)") {
  std::mt19937 rng(99);
  std::normal_distribution<double> nd(0.0, 1.0);
  for (uint32_t deg = 0; deg <= 3; ++deg) {
    CAPTURE(deg);
    const auto cloud = test::random_cloud(40 + deg, 200, deg, {0.0, 0.0, 0.0}, 3.0, -3.0, 0.0);
    for (int trial = 0; trial < 4; ++trial) {
      glm::dvec4 qr(nd(rng), nd(rng), nd(rng), nd(rng));
      qr /= glm::length(qr);
      const glm::dmat3 R = quat_matrix(qr);
      glm::dmat4 T(R);
      T[3] = glm::dvec4(nd(rng) * 50.0, nd(rng) * 50.0, nd(rng), 1.0);
      splat::GaussianCloud placed;
      placed.sh_degree = deg;
      splat::append_placed(placed, cloud, T);
      REQUIRE(placed.size() == cloud.size());
      double worst_cov = 0.0, worst_col = 0.0, worst_pos = 0.0;
      const uint32_t K = cloud.sh_coeffs();
      for (size_t i = 0; i < cloud.size(); ++i) {
        worst_pos = std::max(worst_pos, glm::length(placed.positions[i] - (R * cloud.positions[i] + glm::dvec3(T[3]))));
        const glm::dmat3 want = R * covariance_double(cloud.scales[i], cloud.rotations[i]) * glm::transpose(R);
        const auto got = splat::covariance3d(placed.scales[i], placed.rotations[i]);
        const double w6[6] = {want[0][0], want[1][0], want[2][0], want[1][1], want[2][1], want[2][2]};
        for (int k = 0; k < 6; ++k) worst_cov = std::max(worst_cov, std::fabs(double(got[size_t(k)]) - w6[k]));
        for (int j = 0; j < 8; ++j) {
          glm::dvec3 d(nd(rng), nd(rng), nd(rng));
          d /= glm::length(d);
          const glm::vec3 a = splat::sh_color(&cloud.sh[i * K * 3], deg, glm::vec3(d));
          const glm::vec3 b = splat::sh_color(&placed.sh[i * K * 3], deg, glm::vec3(R * d));
          worst_col = std::max(worst_col, double(glm::length(a - b)));
        }
      }
      CHECK(worst_pos < 1e-9);
      CHECK(worst_cov < 1e-6);
      CHECK(worst_col < 2e-5);
      if (trial == 0) MESSAGE("SH" << deg << ": max |Σ' − RΣRᵀ| " << worst_cov << ", max colour error " << worst_col);
    }
  }
}

TEST_CASE("splat scene: JSON scene with three pose forms, absent frames, relative paths and mixed SH degrees") {
  const auto dir = scratch_dir("icube-splat-scene");
  fs::create_directories(dir / "objects");
  splat::write_gaussians_ply((dir / "static.ply").string(), test::random_cloud(3, 50, 1, {0.0, 0.0, 0.0}, 5.0));
  splat::write_gaussians_ply((dir / "objects" / "car.ply").string(), axis_aligned_car());
  // what the scene reads (positions rounded to float, opacity through logit and sigmoid)
  const auto stat = splat::read_gaussians((dir / "static.ply").string());
  const auto car = splat::read_gaussians((dir / "objects" / "car.ply").string());
  const auto bike = test::random_cloud(4, 10, 0, {0.0, 0.0, 0.0}, 0.5);
  splat::write_gaussians_splat((dir / "objects" / "bike.splat").string(), bike, {false});
  const auto bike_read = splat::read_gaussians((dir / "objects" / "bike.splat").string());
  const std::string json = R"({
    "format": "icube-splat-scene", "version": 1,
    "static": "static.ply",
    "objects": [
      {"id": 10000, "gaussians": "objects/car.ply", "track": [
        {"frame": 0, "object_to_world": [[0, -1, 0, 1], [1, 0, 0, 0.5], [0, 0, 1, 0.3], [0, 0, 0, 1]]},
        {"frame": 1, "position": [1, 0.5, 0.3], "yaw": 1.5707963267948966},
        {"frame": 3, "position": [1, 0.5, 0.3], "quaternion": [0.7071067811865476, 0, 0, 0.7071067811865476]}]},
      {"id": 10001, "gaussians": "objects/bike.splat", "track": [
        {"frame": 1, "position": [-2, 0, 0], "yaw": 0}]}
    ]})";
  scene::write_file_atomic((dir / "scene.json").string(), json);
  const auto scn = splat::read_splat_scene((dir / "scene.json").string());
  CHECK(scn.frames() == 4);
  REQUIRE(scn.objects.size() == 2);
  CHECK(scn.objects[0].id == 10000);
  CHECK(scn.objects[0].source == (dir / "objects" / "car.ply").string());
  CHECK(scn.objects[0].pose(2) == nullptr);
  CHECK(scn.objects[1].pose(0) == nullptr);
  CHECK(scn.objects[1].pose(1) != nullptr);
  CHECK(scn.objects[0].pose(4) == nullptr);

  const auto by_hand = car_yaw90_by_hand(car, {1.0, 0.5, 0.3});
  for (size_t f : {0u, 1u, 3u}) {
    CAPTURE(f);
    const auto got = splat::compose_frame(scn, f);
    auto want = concat(stat, by_hand);
    if (f == 1) {
      splat::append_cloud(want, translated_by_hand(bike_read, {-2.0, 0.0, 0.0}));
    }
    REQUIRE(got.size() == want.size());
    CHECK(got.sh_degree == 1);
    double dp = 0.0, dq = 0.0, dsh = 0.0;
    for (size_t i = 0; i < got.size(); ++i) {
      dp = std::max(dp, glm::length(got.positions[i] - want.positions[i]));
      const auto a = splat::covariance3d(got.scales[i], got.rotations[i]);
      const auto b = splat::covariance3d(want.scales[i], want.rotations[i]);
      for (int k = 0; k < 6; ++k) dq = std::max(dq, double(std::fabs(a[size_t(k)] - b[size_t(k)])));
    }
    dsh = max_diff(got.sh, want.sh);
    CHECK(dp < 1e-12);
    CHECK(dq < 1e-7);
    CHECK(dsh < 1e-6);
    CHECK(got.opacities == want.opacities);
  }
  // frames without objects, and past the end
  CHECK(splat::compose_frame(scn, 2).size() == stat.size());
  CHECK(splat::compose_frame(scn, 100).size() == stat.size());

  // a .splat and a .ply are static-only scenes
  const auto only = splat::read_splat_scene((dir / "objects" / "bike.splat").string());
  CHECK(only.frames() == 0);
  CHECK(!only.has_objects());
  CHECK(only.static_set.size() == bike.size());
  CHECK(splat::compose_frame(only, 7).size() == bike.size());
  fs::remove_all(dir);
}

TEST_CASE("splat scene: JSON errors are one line naming the file and the JSON pointer") {
  const auto dir = scratch_dir("icube-splat-scene-err");
  splat::write_gaussians_ply((dir / "car.ply").string(), axis_aligned_car());
  std::string nan_ply = splat::gaussians_to_ply_bytes(axis_aligned_car());
  {
    // first vertex x = NaN (the body starts after "end_header\n")
    const size_t body = nan_ply.find("end_header\n") + 11;
    const float nan = std::nanf("");
    std::memcpy(&nan_ply[body], &nan, 4);
  }
  scene::write_file_atomic((dir / "nan.ply").string(), nan_ply);
  const std::string head = R"({"format": "icube-splat-scene", "version": 1, )";
  auto obj = [](const std::string& file, const std::string& track, const std::string& extra = "") {
    return R"({"id": 7, "gaussians": ")" + file + R"(", "track": [)" + track + "]" + extra + "}";
  };
  const std::string ok_pose = R"({"frame": 0, "position": [0, 0, 0], "yaw": 0})";
  struct Case {
    std::string text, where, what;
  };
  const std::vector<Case> cases = {
      {"not json", "", "not valid JSON"},
      {"[1, 2]", "/", "expected a JSON object"},
      {R"({"format": "other", "version": 1})", "/format", "icube-splat-scene"},
      {R"({"format": "icube-splat-scene", "version": 2})", "/version", "unsupported version 2"},
      {head + R"("colour": 1})", "/colour", "unknown key"},
      {head + R"("objects": {}})", "/objects", "expected an array"},
      {head + R"("static": "missing.ply"})", "/static", "missing.ply' not found"},
      {head + R"("objects": [)" + obj("car.ply", ok_pose) + ", " + obj("car.ply", ok_pose) + "]}", "/objects/1/id",
       "duplicate object id 7"},
      {head + R"("objects": [)" + obj("gone.splat", ok_pose) + "]}", "/objects/0/gaussians", "not found"},
      {head + R"("objects": [)" + obj("car.ply", ok_pose, R"(, "colour": 1)") + "]}", "/objects/0/colour",
       "unknown key"},
      {head + R"("objects": [)" + obj("car.ply", R"({"position": [0, 0, 0], "yaw": 0})") + "]}",
       "/objects/0/track/0/frame", "missing"},
      {head + R"("objects": [)" + obj("car.ply", R"({"frame": -1, "position": [0, 0, 0], "yaw": 0})") + "]}",
       "/objects/0/track/0/frame", "negative"},
      {head + R"("objects": [)" + obj("car.ply", R"({"frame": 0.5, "position": [0, 0, 0], "yaw": 0})") + "]}",
       "/objects/0/track/0/frame", "integer"},
      {head + R"("objects": [)" + obj("car.ply", ok_pose + ", " + ok_pose) + "]}", "/objects/0/track/1/frame",
       "frame 0 listed twice"},
      {head + R"("frames": 2, "objects": [)" +
           obj("car.ply", R"({"frame": 2, "position": [0, 0, 0], "yaw": 0})") + "]}",
       "/objects/0/track/0/frame", "outside the scene's 2 frames"},
      {head + R"("objects": [)" + obj("car.ply", R"({"frame": 0, "position": [0, 0, 0]})") + "]}",
       "/objects/0/track/0", "needs 'yaw'"},
      {head + R"("objects": [)" + obj("car.ply", R"({"frame": 0, "position": [0, 0], "yaw": 0})") + "]}",
       "/objects/0/track/0/position", "array of 3 numbers"},
      {head + R"("objects": [)" + obj("car.ply", R"({"frame": 0, "position": [0, "a", 0], "yaw": 0})") + "]}",
       "/objects/0/track/0/position/1", "expected a number"},
      {head + R"("objects": [)" + obj("car.ply", R"({"frame": 0, "position": [0, 1e999, 0], "yaw": 0})") + "]}",
       "", "not valid JSON: number overflow parsing '1e999'"},
      {head + R"("objects": [)" + obj("car.ply", R"({"frame": 0, "position": [0, 0, 0], "quaternion": [2, 0, 0, 0]})") +
           "]}",
       "/objects/0/track/0/quaternion", "norm 2"},
      {head + R"("objects": [)" +
           obj("car.ply", R"({"frame": 0, "object_to_world": [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]})") +
           "]}",
       "/objects/0/track/0", "pose is not rigid: rotation is not orthonormal"},
      {head + R"("objects": [)" +
           obj("car.ply", R"({"frame": 0, "object_to_world": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]]})") +
           "]}",
       "/objects/0/track/0", "determinant"},
      {head + R"("objects": [)" +
           obj("car.ply", R"({"frame": 0, "object_to_world": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]})") +
           "]}",
       "/objects/0/track/0", "bottom row"},
      {head + R"("objects": [)" +
           obj("car.ply", R"({"frame": 0, "object_to_world": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]})") + "]}",
       "/objects/0/track/0/object_to_world", "4 rows"},
  };
  for (const auto& c : cases) {
    CAPTURE(c.text);
    try {
      (void)splat::splat_scene_from_json(c.text, "scene.json", dir.string());
      FAIL("no error");
    } catch (const scene::InputError& e) {
      const std::string m = e.what();
      CAPTURE(m);
      CHECK(m.rfind("scene.json: " + (c.where.empty() ? std::string() : c.where + ": "), 0) == 0);
      CHECK(m.find(c.what) != std::string::npos);
      CHECK(m.find('\n') == std::string::npos);
    }
  }
  // an error inside a Gaussian file names that file and its vertex
  try {
    (void)splat::splat_scene_from_json(head + R"("objects": [)" + obj("nan.ply", ok_pose) + "]}", "scene.json",
                                       dir.string());
    FAIL("no error");
  } catch (const scene::InputError& e) {
    const std::string m = e.what();
    CAPTURE(m);
    CHECK(m.rfind((dir / "nan.ply").string() + ": vertex 0: property 'x' is NaN", 0) == 0);
  }
  fs::remove_all(dir);
}

TEST_CASE("splat scene: a rendered frame with a moving object equals rendering the hand-composed cloud (CPU, GPU)") {
  splat::SplatScene scn;
  scn.static_set = test::random_cloud(21, 400, 1, {0.0, 0.0, 0.0}, 3.0);
  splat::SplatObject car;
  car.id = 10000;
  car.gaussians = axis_aligned_car();
  car.poses = {yaw_pose(std::numbers::pi / 2, {1.0, 0.5, 0.3}), yaw_pose(0.0, {-1.5, 0.0, 0.3}), glm::dmat4(1.0)};
  car.present = {1, 1, 0};
  scn.objects.push_back(car);
  scn.frame_count = 3;
  const auto cam = test::look_at_camera({0.5, -9.0, 3.0}, {0.0, 0.0, 0.0}, 80, 56, 70.0, 1.5, -2.0);
  splat::SplatOptions o;
  const std::vector<splat::GaussianCloud> by_hand = {
      concat(scn.static_set, car_yaw90_by_hand(car.gaussians, {1.0, 0.5, 0.3})),
      concat(scn.static_set, translated_by_hand(car.gaussians, {-1.5, 0.0, 0.3})), scn.static_set};
  std::vector<splat::SplatImage> imgs;
  for (size_t f = 0; f < 3; ++f) {
    CAPTURE(f);
    const auto got = splat::render_cpu(splat::compose_frame(scn, f), cam, o);
    const auto want = splat::render_cpu(by_hand[f], cam, o);
    const double d = max_diff(got.rgba, want.rgba);
    MESSAGE("frame " << f << ": max |composed − hand-composed| " << d << " (CPU reference)");
    CHECK(d < 1e-4);
    CHECK(max_diff(got.depth, want.depth) < 1e-3);
    imgs.push_back(got);
  }
  // the object really moves and disappears
  CHECK(max_diff(imgs[0].rgba, imgs[1].rgba) > 0.1);
  CHECK(max_diff(imgs[1].rgba, imgs[2].rgba) > 0.1);

  // the GPU renderer on the composed frame against the CPU reference of the hand-composed cloud
  splat::SplatRendererGpu gpu(test::gpu_context());
  const auto gi = gpu.render(gpu.upload(splat::compose_frame(scn, 0)), cam, o);
  const auto ci = splat::render_cpu(by_hand[0], cam, o);
  REQUIRE(gi.rgba.size() == ci.rgba.size());
  size_t band = 0;
  double interior = 0.0;
  for (size_t p = 0; p < size_t{gi.width} * gi.height; ++p) {
    double d = 0.0;
    for (int c = 0; c < 4; ++c) d = std::max(d, std::fabs(double(gi.rgba[4 * p + c]) - double(ci.rgba[4 * p + c])));
    if (!(d <= 1e-3)) ++band;
    else interior = std::max(interior, d);
  }
  MESSAGE("GPU frame 0 vs CPU hand-composed: " << band << " pixels over 1e-3, max elsewhere " << interior);
  CHECK(double(band) <= 0.01 * double(gi.width) * gi.height);
}
