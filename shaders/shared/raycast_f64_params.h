// The camera of a camera-mode cast in double, for shaders/raycast/exact.comp
// (binding 7): the semantic chord of a voxel within float rounding of eps_sem is
// recomputed from these with the CPU reference's formulas (engine/render/camera.cpp
// camera_ray, engine/render/raycast_cpu.cpp cast_ray_cpu): the camera-frame
// direction normalize(((u + po - cx) / fx, (v + po - cy) / fy, 1)), rotated by R
// (camera-to-world, row-major) and normalised, divided by the voxel size; the
// origin is (off_x, off_y, off_z) relative to the reference voxel. Shared by GLSL
// (with GL_EXT_shader_explicit_arithmetic_types_float64) and C++.
#ifndef ICUBE_RAYCAST_F64_PARAMS_H
#define ICUBE_RAYCAST_F64_PARAMS_H
#include "gpu_types.h"
#include "raycast_params.h"

ICUBE_SHADER_NAMESPACE_BEGIN

struct RaycastCameraF64 {
  RAYCAST_EXACT_CAMERA_FIELDS(double)
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(RaycastCameraF64, 160);
ICUBE_CHECK_LAYOUT(RaycastCameraF64, fx, 72);
ICUBE_CHECK_LAYOUT(RaycastCameraF64, off_x, 112);
ICUBE_CHECK_LAYOUT(RaycastCameraF64, t_max, 152);

#endif
