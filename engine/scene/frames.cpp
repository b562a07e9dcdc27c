// Frame conversions: camera-pose column permutations, camera poses from ego
// poses and extrinsics, oriented boxes and their corners (see frames.h).
#include "scene/frames.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace icube::scene {

glm::dmat4 opencv_to_flu(const glm::dmat4& m) {
  glm::dmat4 r;
  r[0] = m[2];   // forward = OpenCV z
  r[1] = -m[0];  // left    = -OpenCV x (right)
  r[2] = -m[1];  // up      = -OpenCV y (down)
  r[3] = m[3];
  return r;
}

glm::dmat4 flu_to_opencv(const glm::dmat4& m) {
  glm::dmat4 r;
  r[0] = -m[1];  // right   = -left
  r[1] = -m[2];  // down    = -up
  r[2] = m[0];   // forward = FLU x
  r[3] = m[3];
  return r;
}

glm::dmat4 camera_to_world_flu(const EgoPose& ego, const Camera& camera) {
  return ego.ego_to_world * camera.camera_to_ego;
}

glm::dmat4 camera_to_world_opencv(const EgoPose& ego, const Camera& camera) {
  return flu_to_opencv(camera_to_world_flu(ego, camera));
}

glm::dmat3 box_rotation(const BoxState& box) {
  const double ch = std::cos(box.heading), sh = std::sin(box.heading);
  const double cp = std::cos(box.pitch), sp = std::sin(box.pitch);
  const double cr = std::cos(box.roll), sr = std::sin(box.roll);
  // glm constructors take columns.
  const glm::dmat3 rz(ch, sh, 0.0, -sh, ch, 0.0, 0.0, 0.0, 1.0);
  const glm::dmat3 ry(cp, 0.0, -sp, 0.0, 1.0, 0.0, sp, 0.0, cp);
  const glm::dmat3 rx(1.0, 0.0, 0.0, 0.0, cr, sr, 0.0, -sr, cr);
  return rz * ry * rx;
}

glm::dmat4 box_to_world(const BoxState& box) {
  glm::dmat4 m(box_rotation(box));
  m[3] = glm::dvec4(box.center, 1.0);
  return m;
}

BoxCorners box_corners_local(double length, double width, double height) {
  static constexpr int kUnit[8][3] = {{1, 1, 1}, {1, 0, 1}, {0, 0, 1}, {0, 1, 1},
                                      {1, 1, 0}, {1, 0, 0}, {0, 0, 0}, {0, 1, 0}};
  const glm::dvec3 lwh(length, width, height);
  BoxCorners c;
  for (int i = 0; i < 8; ++i)
    c[size_t(i)] = glm::dvec3(kUnit[i][0], kUnit[i][1], kUnit[i][2]) * lwh - lwh * 0.5;
  return c;
}

BoxCorners box_corners(const BoxState& box) {
  const glm::dmat3 r = box_rotation(box);
  BoxCorners c = box_corners_local(box.length, box.width, box.height);
  for (glm::dvec3& p : c) p = box.center + r * p;
  return c;
}

double wrap_angle(double a) {
  constexpr double kPi = std::numbers::pi, kTwoPi = 2.0 * std::numbers::pi;
  if (!std::isfinite(a) || (a >= -kPi && a < kPi)) return a;
  double r = std::fmod(a + kPi, kTwoPi);
  if (r < 0.0) r += kTwoPi;
  r -= kPi;
  return r < kPi ? r : -kPi;  // fmod rounding can land exactly on +pi
}

double heading_from_corners(const BoxCorners& c) {
  return wrap_angle(std::atan2(c[0].y - c[3].y, c[0].x - c[3].x));
}

Camera rescale_camera(const Camera& camera, uint32_t width, uint32_t height) {
  if (camera.width == 0 || camera.height == 0 || width == 0 || height == 0)
    throw std::invalid_argument("rescale_camera: camera '" + camera.name + "' or the target has a zero size");
  Camera r = camera;
  const double sx = double(width) / double(camera.width), sy = double(height) / double(camera.height);
  r.fx *= sx;
  r.cx *= sx;
  r.fy *= sy;
  r.cy *= sy;
  r.width = width;
  r.height = height;
  return r;
}

Camera waymo_front_camera_native(const glm::dvec3& mount) {
  Camera c;
  c.name = "front";
  const double half_fov = kWaymoFrontHorizontalFovDegrees * 0.5 * std::numbers::pi / 180.0;
  c.fx = c.fy = 0.5 * double(kWaymoFrontNativeWidth) / std::tan(half_fov);
  c.cx = 0.5 * double(kWaymoFrontNativeWidth);
  c.cy = 0.5 * double(kWaymoFrontNativeHeight);
  c.width = kWaymoFrontNativeWidth;
  c.height = kWaymoFrontNativeHeight;
  c.camera_to_ego = glm::dmat4(1.0);
  c.camera_to_ego[3] = glm::dvec4(mount, 1.0);
  return c;
}

Camera waymo_front_camera(const glm::dvec3& mount) {
  return rescale_camera(waymo_front_camera_native(mount), kInfiniCubeWidth, kInfiniCubeHeight);
}

}  // namespace icube::scene
