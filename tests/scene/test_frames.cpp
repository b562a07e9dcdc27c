// Frame conversions (engine/scene/frames.h): the OpenCV/FLU c2w column
// permutations, camera poses from ego poses and extrinsics, box rotation
// order, InfiniCube's corner order and heading encoding, and double
// precision far from the origin.
#include "scene/frames.h"

#include <doctest/doctest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

using namespace icube::scene;

namespace {

constexpr double kPi = std::numbers::pi;

bool near(const glm::dvec3& a, const glm::dvec3& b, double tol) {
  return std::abs(a.x - b.x) <= tol && std::abs(a.y - b.y) <= tol && std::abs(a.z - b.z) <= tol;
}

glm::dvec3 col(const glm::dmat4& m, int c) { return glm::dvec3(m[c]); }

// A random rigid transform (fixed seed by the caller).
glm::dmat4 random_rigid(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> angle(-kPi, kPi), pos(-1000.0, 1000.0);
  glm::dmat4 m = glm::translate(glm::dmat4(1.0), glm::dvec3(pos(rng), pos(rng), pos(rng)));
  m = glm::rotate(m, angle(rng), glm::normalize(glm::dvec3(pos(rng), pos(rng), pos(rng))));
  return m;
}

bool orthonormal_right_handed(const glm::dmat4& m, double tol) {
  const glm::dmat3 r(m);
  const glm::dmat3 rtr = glm::transpose(r) * r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (std::abs(rtr[i][j] - (i == j ? 1.0 : 0.0)) > tol) return false;
  return std::abs(glm::determinant(r) - 1.0) <= tol;
}

}  // namespace

TEST_CASE("frames: opencv_to_flu and flu_to_opencv are the documented column permutations") {
  // On the identity the columns are the unit vectors, so the result shows the permutation itself.
  const glm::dmat4 a = opencv_to_flu(glm::dmat4(1.0));
  CHECK(col(a, 0) == glm::dvec3(0, 0, 1));   // c2
  CHECK(col(a, 1) == glm::dvec3(-1, 0, 0));  // -c0
  CHECK(col(a, 2) == glm::dvec3(0, -1, 0));  // -c1
  CHECK(a[3] == glm::dvec4(0, 0, 0, 1));     // c3
  const glm::dmat4 b = flu_to_opencv(glm::dmat4(1.0));
  CHECK(col(b, 0) == glm::dvec3(0, -1, 0));  // -c1
  CHECK(col(b, 1) == glm::dvec3(0, 0, -1));  // -c2
  CHECK(col(b, 2) == glm::dvec3(1, 0, 0));   // c0
  CHECK(b[3] == glm::dvec4(0, 0, 0, 1));
}

TEST_CASE("frames: the permutations invert each other exactly and keep poses orthonormal") {
  std::mt19937_64 rng(20250101);
  for (int i = 0; i < 200; ++i) {
    const glm::dmat4 m = random_rigid(rng);
    REQUIRE(orthonormal_right_handed(m, 1e-12));
    const glm::dmat4 flu = opencv_to_flu(m), cv = flu_to_opencv(m);
    CHECK(flu_to_opencv(flu) == m);  // negation and reordering are exact
    CHECK(opencv_to_flu(cv) == m);
    CHECK(orthonormal_right_handed(flu, 1e-12));
    CHECK(orthonormal_right_handed(cv, 1e-12));
    CHECK(flu[3] == m[3]);
    CHECK(cv[3] == m[3]);
  }
}

TEST_CASE("frames: a camera looking along FLU +x has its OpenCV z along world +x") {
  EgoPose ego;  // identity
  Camera cam;   // identity extrinsic: camera FLU = ego FLU
  const glm::dmat4 c2w = camera_to_world_opencv(ego, cam);
  CHECK(col(c2w, 2) == glm::dvec3(1, 0, 0));   // optical axis forward
  CHECK(col(c2w, 0) == glm::dvec3(0, -1, 0));  // image right = world -y (right of the car)
  CHECK(col(c2w, 1) == glm::dvec3(0, 0, -1));  // image down = world -z

  // Ego yawed by +90° (facing world +y): the optical axis follows.
  ego.ego_to_world = glm::rotate(glm::dmat4(1.0), kPi / 2, glm::dvec3(0, 0, 1));
  const glm::dmat4 yawed = camera_to_world_opencv(ego, cam);
  CHECK(near(col(yawed, 2), glm::dvec3(0, 1, 0), 1e-15));
  CHECK(near(col(yawed, 0), glm::dvec3(1, 0, 0), 1e-15));
}

TEST_CASE("frames: camera pose = ego pose · extrinsic (extrinsic applied first)") {
  EgoPose ego;
  ego.ego_to_world = glm::translate(glm::dmat4(1.0), glm::dvec3(10, 20, 0));
  ego.ego_to_world = glm::rotate(ego.ego_to_world, kPi / 2, glm::dvec3(0, 0, 1));
  Camera cam;
  cam.camera_to_ego = glm::translate(glm::dmat4(1.0), glm::dvec3(2, 0, 1.5));  // 2 m forward, 1.5 m up
  const glm::dmat4 flu = camera_to_world_flu(ego, cam);
  // Forward on a car facing +y is +y: the camera sits at (10, 22, 1.5).
  CHECK(near(col(flu, 3), glm::dvec3(10, 22, 1.5), 1e-14));
  CHECK(near(col(camera_to_world_opencv(ego, cam), 3), glm::dvec3(10, 22, 1.5), 1e-14));
}

TEST_CASE("frames: box corners come in InfiniCube's order") {
  const BoxCorners c = box_corners_local(4.0, 2.0, 1.5);
  const glm::dvec3 want[8] = {{2, 1, 0.75},  {2, -1, 0.75},  {-2, -1, 0.75},  {-2, 1, 0.75},
                              {2, 1, -0.75}, {2, -1, -0.75}, {-2, -1, -0.75}, {-2, 1, -0.75}};
  for (int i = 0; i < 8; ++i) CHECK(c[size_t(i)] == want[i]);

  // In the world: heading 90° turns the length axis to +y, then the centre is added.
  BoxState box;
  box.center = {100, 200, 3};
  box.length = 4;
  box.width = 2;
  box.height = 1.5;
  box.heading = kPi / 2;
  const BoxCorners w = box_corners(box);
  CHECK(near(w[0], glm::dvec3(99, 202, 3.75), 1e-13));
  CHECK(near(w[6], glm::dvec3(101, 198, 2.25), 1e-13));
}

TEST_CASE("frames: box rotation is Rz(heading)·Ry(pitch)·Rx(roll)") {
  BoxState b;
  b.heading = kPi / 2;
  b.roll = kPi / 2;
  // Rz(90)·Rx(90) sends the box +y axis to +z (Rx·Rz would send it to -x).
  CHECK(near(box_rotation(b) * glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1), 1e-15));
  b.roll = 0;
  b.pitch = kPi / 2;
  // Rz(90)·Ry(90) sends +x to -z (Ry·Rz would send it to +y).
  CHECK(near(box_rotation(b) * glm::dvec3(1, 0, 0), glm::dvec3(0, 0, -1), 1e-15));
  const glm::dmat4 m = box_to_world(b);
  CHECK(orthonormal_right_handed(m, 1e-15));
}

TEST_CASE("frames: heading_from_corners recovers the heading, also with pitch and roll") {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> yaw(-kPi, kPi), tilt(-0.3, 0.3), size(0.2, 20.0), pos(-5e4, 5e4);
  for (int i = 0; i < 500; ++i) {
    BoxState b;
    b.center = {pos(rng), pos(rng), pos(rng) * 1e-3};
    b.length = size(rng);
    b.width = size(rng);
    b.height = size(rng);
    b.heading = yaw(rng);
    b.pitch = tilt(rng);
    b.roll = tilt(rng);
    const double h = heading_from_corners(box_corners(b));
    CHECK(h >= -kPi);
    CHECK(h < kPi);
    // Far from the origin corner differences lose ~1e-11 m; over >= 0.2 m that is < 1e-9 rad.
    CHECK(std::abs(wrap_angle(h - b.heading)) < 1e-9);
  }
  // A box facing world -x: atan2(+0, -4) = +pi, which the encoding reports as -pi.
  BoxCorners facing_back{};
  facing_back[0] = {-2, 0, 0};
  facing_back[3] = {2, 0, 0};
  CHECK(heading_from_corners(facing_back) == -kPi);
}

TEST_CASE("frames: wrap_angle maps into [-pi, pi)") {
  CHECK(wrap_angle(0.5) == 0.5);
  CHECK(wrap_angle(-kPi) == -kPi);
  CHECK(wrap_angle(kPi) == -kPi);
  CHECK(wrap_angle(3 * kPi) == -kPi);
  CHECK(std::abs(wrap_angle(7.0) - (7.0 - 2 * kPi)) < 1e-15);
  CHECK(std::abs(wrap_angle(-7.0) - (-7.0 + 2 * kPi)) < 1e-15);
  CHECK(std::isnan(wrap_angle(std::nan(""))));
}

TEST_CASE("frames: a camera 100 km from the origin keeps sub-micrometre precision") {
  EgoPose ego;
  ego.ego_to_world = glm::translate(glm::dmat4(1.0), glm::dvec3(100000.25, -73000.5, 12.0));
  Camera cam;
  cam.camera_to_ego = glm::translate(glm::dmat4(1.0), glm::dvec3(1.5, 0.125, 2.0));
  const glm::dvec3 t = col(camera_to_world_opencv(ego, cam), 3);
  CHECK(t == glm::dvec3(100001.75, -73000.375, 14.0));  // all exactly representable

  // Moving the camera 1 mm forward moves the world pose 1 mm (float's spacing at 1e5 m is ~8 mm).
  cam.camera_to_ego[3].x += 0.001;
  const glm::dvec3 t2 = col(camera_to_world_opencv(ego, cam), 3);
  CHECK(std::abs((t2.x - t.x) - 0.001) < 1e-9);
  CHECK(t2.y == t.y);

  // Also under rotation: a yawed ego far away; the camera stays 1.5 m ahead to 1e-9 m.
  ego.ego_to_world = glm::rotate(ego.ego_to_world, 0.7, glm::dvec3(0, 0, 1));
  cam.camera_to_ego = glm::translate(glm::dmat4(1.0), glm::dvec3(1.5, 0.0, 0.0));
  const glm::dvec3 p = col(camera_to_world_opencv(ego, cam), 3);
  const glm::dvec3 want(100000.25 + 1.5 * std::cos(0.7), -73000.5 + 1.5 * std::sin(0.7), 12.0);
  CHECK(near(p, want, 1e-9));
}

TEST_CASE("frames: Waymo FRONT preset is rescaled to 832x480 as the conventions say") {
  const Camera native = waymo_front_camera_native();
  CHECK(native.width == 1920);
  CHECK(native.height == 1280);
  CHECK(native.fx == native.fy);
  CHECK(std::abs(2 * std::atan(960.0 / native.fx) * 180 / kPi - 50.0) < 1e-12);
  CHECK(native.cx == 960.0);
  CHECK(native.cy == 640.0);

  const Camera c = waymo_front_camera();
  CHECK(c.width == 832);
  CHECK(c.height == 480);
  CHECK(c.fx == doctest::Approx(native.fx * 832.0 / 1920.0).epsilon(1e-15));  // 0.4333
  CHECK(c.fy == doctest::Approx(native.fy * 0.375).epsilon(1e-15));
  CHECK(c.cx == 416.0);
  CHECK(c.cy == 240.0);
  CHECK(std::abs(c.fx - 892.1148789319764) < 1e-9);
  CHECK(std::abs(c.fy - 772.0224913834411) < 1e-9);
  // Vertical FOV ≈ 35° (conventions §1).
  const double vfov = 2 * std::atan(240.0 / c.fy) * 180 / kPi;
  CHECK(std::abs(vfov - 35.0) < 0.5);
  CHECK(col(c.camera_to_ego, 3) == kWaymoFrontMount);
  CHECK(glm::dmat3(c.camera_to_ego) == glm::dmat3(1.0));

  Camera zero;
  CHECK_THROWS_AS(rescale_camera(zero, 832, 480), std::invalid_argument);
}
