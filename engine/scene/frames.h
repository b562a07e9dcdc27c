// Frame conversions between the scene's frames (conventions §1, §6):
//
//   world   Waymo global / OpenDRIVE inertial, metres, z up
//   FLU     x forward, y left, z up (ego, camera extrinsics, boxes)
//   OpenCV  x right, y down, z forward (every stored camera pose, c2w 4×4)
//
// Matrices are glm::dmat4, column-major: m[0] is the first column ("c0"),
// m[3] the translation. Everything stays in double: a camera 100 km from the
// origin keeps sub-micrometre precision; later stages subtract an origin
// before going to float.
#pragma once

#include "scene/scene.h"

#include <glm/glm.hpp>

#include <array>

namespace icube::scene {

// Camera-to-world column permutations (InfiniCube `camera/base.py`):
//   opencv_to_flu: [c2, -c0, -c1, c3]    flu_to_opencv: [-c1, -c2, c0, c3]
// Each is the inverse of the other; both keep the translation column.
glm::dmat4 opencv_to_flu(const glm::dmat4& c2w_opencv);
glm::dmat4 flu_to_opencv(const glm::dmat4& c2w_flu);

// Camera (FLU) to world = ego_to_world · camera_to_ego.
glm::dmat4 camera_to_world_flu(const EgoPose& ego, const Camera& camera);
// The OpenCV camera-to-world pose InfiniCube stores: flu_to_opencv(ego_to_world · camera_to_ego).
glm::dmat4 camera_to_world_opencv(const EgoPose& ego, const Camera& camera);

// Box rotation Rz(heading)·Ry(pitch)·Rx(roll) (right-handed, angles in radians).
glm::dmat3 box_rotation(const BoxState& box);
// Box (centre, axes x = length, y = width, z = height) to world.
glm::dmat4 box_to_world(const BoxState& box);

// The 8 corners in InfiniCube's order (`utils/bbox_utils.py`):
// [1,1,1],[1,0,1],[0,0,1],[0,1,1],[1,1,0],[1,0,0],[0,0,0],[0,1,0] × lwh − lwh/2,
// so 0-3 are the top face and corner 0 = (+l/2, +w/2, +h/2).
using BoxCorners = std::array<glm::dvec3, 8>;
BoxCorners box_corners_local(double length, double width, double height);
// The same corners in the world frame (box_to_world applied).
BoxCorners box_corners(const BoxState& box);

// InfiniCube's heading encoding: atan2(c0.y − c3.y, c0.x − c3.x), the yaw of
// the box +x (length) axis, in [-pi, pi). For |pitch| < pi/2 this recovers
// BoxState::heading exactly up to rounding.
double heading_from_corners(const BoxCorners& corners);

// Wraps an angle to [-pi, pi) (NaN and infinities are returned unchanged).
double wrap_angle(double radians);

// ---- default camera --------------------------------------------------------------

// The resolution InfiniCube renders and generates at (conventions §1, §13).
inline constexpr uint32_t kInfiniCubeWidth = 832;
inline constexpr uint32_t kInfiniCubeHeight = 480;

// Waymo FRONT camera at its native 1920×1280. The conventions give no
// numbers, so these are derived, not measured: a 50° horizontal field of view
// with square pixels and a centred principal point, fx = fy = 960 / tan(25°)
// = 2058.73 px. That gives a 34.5° vertical FOV, matching the ≈ 35° the
// conventions quote. Replace with a clip's real calibration when one exists.
inline constexpr uint32_t kWaymoFrontNativeWidth = 1920;
inline constexpr uint32_t kWaymoFrontNativeHeight = 1280;
inline constexpr double kWaymoFrontHorizontalFovDegrees = 50.0;

// Where the preset mounts the camera on the ego (FLU, metres): roughly above
// the windscreen of a Waymo car. An assumption, not calibration.
inline constexpr glm::dvec3 kWaymoFrontMount{1.5, 0.0, 2.0};

// `camera` with its intrinsics rescaled from (camera.width × camera.height)
// to (width × height) as InfiniCube does: fx, cx × width/camera.width;
// fy, cy × height/camera.height (aspect not preserved). Throws std::invalid_argument
// when either size is zero.
Camera rescale_camera(const Camera& camera, uint32_t width, uint32_t height);

// The Waymo FRONT preset at 832×480: fx, cx scaled by 832/1920 (0.4333),
// fy, cy by 480/1280 (0.375). camera_to_ego: looking forward (identity
// rotation in FLU), translated to `mount`.
Camera waymo_front_camera(const glm::dvec3& mount = kWaymoFrontMount);
// The same preset at the native 1920×1280.
Camera waymo_front_camera_native(const glm::dvec3& mount = kWaymoFrontMount);

}  // namespace icube::scene
