// The camera of a camera-mode cast in double, for shaders/raycast/exact.comp
// (binding 6): the semantic chord of a voxel within float rounding of eps_sem is
// recomputed from these with the CPU reference's formulas (engine/render/camera.cpp
// camera_ray, engine/render/raycast_cpu.cpp cast_ray_cpu): the camera-frame
// direction normalize(((u + po - cx) / fx, (v + po - cy) / fy, 1)), rotated by R
// (camera-to-world, row-major) and normalised, divided by the voxel size; the
// origin is (off_x, off_y, off_z) relative to the reference voxel. Shared by GLSL
// (with GL_EXT_shader_explicit_arithmetic_types_float64) and C++.
#ifndef ICUBE_RAYCAST_F64_PARAMS_H
#define ICUBE_RAYCAST_F64_PARAMS_H
#include "gpu_types.h"

ICUBE_SHADER_NAMESPACE_BEGIN

struct RaycastCameraF64 {
  double r00, r01, r02, r10, r11, r12, r20, r21, r22;  // camera-to-world rotation, row-major
  double fx, fy, cx, cy;
  double pixel_offset;       // 0 or 0.5
  double off_x, off_y, off_z;  // camera position - reference voxel corner, voxel units
  double voxel_size;         // metres
  double eps_sem;            // metres
  double t_max;              // metres
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(RaycastCameraF64, 160);
ICUBE_CHECK_LAYOUT(RaycastCameraF64, fx, 72);
ICUBE_CHECK_LAYOUT(RaycastCameraF64, off_x, 112);
ICUBE_CHECK_LAYOUT(RaycastCameraF64, t_max, 152);

#endif
