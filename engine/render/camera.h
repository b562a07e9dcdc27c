// Pinhole cameras and their rays for the voxel ray caster (conventions §10.2).
//
// Intrinsics are OpenCV's (fx, fy, cx, cy in pixels, image width × height);
// the pose is camera-to-world (4x4, OpenCV axes: x right, y down, z forward,
// world metres). The ray through pixel (u, v) has direction
//   d = R_c2w · normalize(K^-1 [u + o, v + o, 1]),   o = 0 (InfiniCube: integer
// pixels, u = 0..W-1, v = 0..H-1, no +0.5) or o = 0.5 (pixel centres),
// and starts at the camera centre; no near/far, no distortion. d_cam.z (the
// camera-frame z of the unit direction) turns a ray t into z-depth: z = t · d_cam.z.
// Pixels are numbered row-major: ray index = v · W + u.
#pragma once

#include "scene/scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::render {

enum class PixelConvention {
  Integer,  // InfiniCube: (u, v)
  Centre,   // (u + 0.5, v + 0.5)
};

struct PinholeIntrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  uint32_t width = 0, height = 0;
};

struct Camera {
  PinholeIntrinsics K;
  glm::dmat4 c2w{1.0};  // camera-to-world, OpenCV camera axes
};

struct Ray {
  glm::dvec3 origin{0.0};  // world metres
  glm::dvec3 dir{0.0, 0.0, 1.0};  // unit, world
};

// Throws std::invalid_argument for a zero size or non-finite / non-positive focal lengths.
void validate_camera(const Camera& cam);

double pixel_offset(PixelConvention pc);
// normalize(K^-1 [u + o, v + o, 1]) in the camera frame.
glm::dvec3 camera_ray_dir_cam(const PinholeIntrinsics& K, uint32_t u, uint32_t v, PixelConvention pc);
// The world ray through pixel (u, v).
Ray camera_ray(const Camera& cam, uint32_t u, uint32_t v, PixelConvention pc);
// All W·H rays, row-major.
std::vector<Ray> camera_rays(const Camera& cam, PixelConvention pc);
// M = R_c2w · K^-1 (row-major in the result): d = normalize(M · (u + o, v + o, 1)).
glm::dmat3 camera_ray_matrix(const Camera& cam);
glm::dvec3 camera_position(const Camera& cam);

// A scene camera (intrinsics + camera_to_ego, FLU as in scene.h) at an ego pose (ego_to_world), as an
// OpenCV camera-to-world pose (frames.h flu_to_opencv).
Camera camera_from_scene(const scene::Camera& cam, const glm::dmat4& ego_to_world);

}  // namespace icube::render
