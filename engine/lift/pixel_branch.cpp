// Pixel-branch Gaussians for mid-ground pixels; see pixel_branch.h.
#include "lift/pixel_branch.h"

#include "lift/static_lift.h"
#include "world/semantics.h"

#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace icube::lift {

std::optional<double> frame_ground_z(const world::VoxelGrid& grid, const std::vector<shader::RaycastHit>& hits) {
  std::vector<int> tops;
  for (const shader::RaycastHit& h : hits) {
    if ((h.flags & RAYCAST_FLAG_SEM) == 0u) continue;
    if (h.sem_class != uint32_t(world::SemanticClass::Road) && h.sem_class != uint32_t(world::SemanticClass::LaneMarker))
      continue;
    tops.push_back(h.ijk_z + 1);
  }
  if (tops.empty()) return std::nullopt;
  const size_t mid = tops.size() / 2;
  std::nth_element(tops.begin(), tops.begin() + std::ptrdiff_t(mid), tops.end());
  return grid.origin().z + double(tops[mid]) * grid.voxel_size();
}

bool is_midground(uint8_t sky, uint16_t instance, const shader::RaycastHit& hit) {
  return sky == 0 && instance < kDynamicInstanceMin && (hit.flags & RAYCAST_FLAG_SEM) == 0u;
}

PixelBranchStats lift_midground_pixels(const world::VoxelGrid& grid, const render::Camera& cam,
                                       render::PixelConvention pixels, const std::vector<uint8_t>& rgb,
                                       const std::vector<uint8_t>& sky, const std::vector<uint16_t>& instance,
                                       const std::vector<shader::RaycastHit>& hits, splat::GaussianCloud& out) {
  render::validate_camera(cam);
  const size_t W = cam.K.width, H = cam.K.height;
  if (rgb.size() != W * H * 3 || sky.size() != W * H || instance.size() != W * H || hits.size() != W * H)
    throw std::invalid_argument("lift_midground_pixels: image or hit sizes disagree with the camera");
  if (out.size() > 0 && out.sh_degree != 0) throw std::invalid_argument("lift_midground_pixels: the cloud is not SH0");
  out.sh_degree = 0;
  PixelBranchStats st;
  const std::optional<double> ground = frame_ground_z(grid, hits);
  // The world's occupied xy bounds in metres (empty world: no backdrop, z_far).
  const world::IjkBounds b = grid.bounds();
  const double vs = grid.voxel_size();
  const glm::dvec2 lo = glm::dvec2(grid.origin()) + glm::dvec2(b.min) * vs;
  const glm::dvec2 hi = glm::dvec2(grid.origin()) + glm::dvec2(b.max + 1) * vs;
  const glm::dvec3 o = render::camera_position(cam);
  const bool inside = !b.empty() && o.x >= lo.x && o.x <= hi.x && o.y >= lo.y && o.y <= hi.y;
  const glm::dmat3 R(cam.c2w);
  const glm::dvec3 x_axis = glm::normalize(R[0]);
  const glm::dquat q = glm::normalize(glm::quat_cast(R));
  const glm::vec4 q_wxyz(float(q.w), float(q.x), float(q.y), float(q.z));
  constexpr double kInf = std::numeric_limits<double>::infinity();

  for (uint32_t v = 0; v < H; ++v)
    for (uint32_t u = 0; u < W; ++u) {
      const size_t i = size_t(v) * W + u;
      if (!is_midground(sky[i], instance[i], hits[i])) continue;
      const glm::dvec3 dc = render::camera_ray_dir_cam(cam.K, u, v, pixels);
      const glm::dvec3 d = glm::normalize(R * dc);
      double t = kInf;
      if (ground && d.z < 0.0 && *ground < o.z) {
        t = (*ground - o.z) / d.z;
        ++st.ground;
      } else {
        if (inside) {
          for (int a = 0; a < 2; ++a)
            if (d[a] != 0.0) t = std::min(t, ((d[a] > 0.0 ? hi[a] : lo[a]) - o[a]) / d[a]);
        }
        ++st.backdrop;
      }
      double z = std::isfinite(t) ? t * dc.z : kPixelZFar;
      if (z < kPixelZNear || z > kPixelZFar) {
        z = std::clamp(z, kPixelZNear, kPixelZFar);
        ++st.clamped;
      }
      const glm::dvec3 p = o + (z / dc.z) * d;
      const double f = z / cam.K.fx;
      const glm::vec3 sigma = kPixelSigma * float(f);
      float coeffs[3];
      for (int c = 0; c < 3; ++c) coeffs[c] = float((double(rgb[3 * i + size_t(c)]) / 255.0 - 0.5) / splat::kShC0);
      for (double side : {-0.25, 0.25}) out.add(p + side * f * x_axis, sigma, q_wxyz, kSurfaceOpacity, coeffs);
      ++st.pixels;
      st.gaussians += 2;
    }
  return st;
}

}  // namespace icube::lift
