// Pinhole camera rays; see camera.h.
#include "render/camera.h"

#include "scene/frames.h"

#include <cmath>
#include <stdexcept>

namespace icube::render {

void validate_camera(const Camera& cam) {
  const PinholeIntrinsics& K = cam.K;
  if (K.width == 0 || K.height == 0) throw std::invalid_argument("camera: zero image size");
  if (!(std::isfinite(K.fx) && std::isfinite(K.fy) && K.fx > 0.0 && K.fy > 0.0))
    throw std::invalid_argument("camera: focal lengths must be finite and positive");
  if (!std::isfinite(K.cx) || !std::isfinite(K.cy)) throw std::invalid_argument("camera: non-finite principal point");
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(cam.c2w[c][r])) throw std::invalid_argument("camera: non-finite pose");
}

double pixel_offset(PixelConvention pc) { return pc == PixelConvention::Centre ? 0.5 : 0.0; }

glm::dvec3 camera_ray_dir_cam(const PinholeIntrinsics& K, uint32_t u, uint32_t v, PixelConvention pc) {
  const double o = pixel_offset(pc);
  return glm::normalize(glm::dvec3((u + o - K.cx) / K.fx, (v + o - K.cy) / K.fy, 1.0));
}

Ray camera_ray(const Camera& cam, uint32_t u, uint32_t v, PixelConvention pc) {
  const glm::dmat3 R(cam.c2w);
  return {camera_position(cam), glm::normalize(R * camera_ray_dir_cam(cam.K, u, v, pc))};
}

std::vector<Ray> camera_rays(const Camera& cam, PixelConvention pc) {
  validate_camera(cam);
  std::vector<Ray> rays;
  rays.reserve(static_cast<size_t>(cam.K.width) * cam.K.height);
  for (uint32_t v = 0; v < cam.K.height; ++v)
    for (uint32_t u = 0; u < cam.K.width; ++u) rays.push_back(camera_ray(cam, u, v, pc));
  return rays;
}

glm::dmat3 camera_ray_matrix(const Camera& cam) {
  const PinholeIntrinsics& K = cam.K;
  // glm is column-major: Kinv[c][r].
  glm::dmat3 Kinv(1.0);
  Kinv[0][0] = 1.0 / K.fx;
  Kinv[1][1] = 1.0 / K.fy;
  Kinv[2][0] = -K.cx / K.fx;
  Kinv[2][1] = -K.cy / K.fy;
  return glm::dmat3(cam.c2w) * Kinv;
}

glm::dvec3 camera_position(const Camera& cam) { return glm::dvec3(cam.c2w[3]); }

Camera camera_from_scene(const scene::Camera& cam, const glm::dmat4& ego_to_world) {
  Camera c;
  c.K = {cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height};
  c.c2w = scene::flu_to_opencv(ego_to_world * cam.camera_to_ego);  // camera_to_ego is FLU (scene.h)
  return c;
}

}  // namespace icube::render
