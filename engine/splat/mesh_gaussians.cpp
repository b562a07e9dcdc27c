// Surface Gaussians of a triangle mesh (see mesh_gaussians.h).
#include "splat/mesh_gaussians.h"

#include "splat/splat_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::splat {

namespace {

bool positive_finite(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

GaussianCloud mesh_surface_gaussians(const world::TriangleMesh& mesh, const MeshPaint& paint,
                                     const MeshGaussianOptions& options) {
  if (!positive_finite(options.spacing) || !(options.normal_sigma > 0.0) || !std::isfinite(options.normal_sigma))
    throw std::invalid_argument("mesh_surface_gaussians: spacing and normal_sigma must be positive and finite");
  const double sun_len = glm::length(paint.sun);
  if (!positive_finite(sun_len)) throw std::invalid_argument("mesh_surface_gaussians: the sun direction is zero");
  const glm::dvec3 sun = paint.sun / sun_len;
  GaussianCloud out;
  out.sh_degree = 0;
  if (mesh.triangles.empty()) return out;
  double z_min = std::numeric_limits<double>::max();
  for (const glm::dvec3& p : mesh.positions) z_min = std::min(z_min, p.z);

  // First pass: how many Gaussians, checked against the budget before anything is allocated.
  auto corners = [&](const glm::uvec3& t, glm::dvec3& a, glm::dvec3& b, glm::dvec3& c) {
    a = mesh.positions.at(t.x), b = mesh.positions.at(t.y), c = mesh.positions.at(t.z);
  };
  auto longest_edge = [](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    return std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
  };
  auto subdivisions = [&](double longest) { return std::max(1.0, std::ceil(longest / options.spacing)); };
  double total = 0.0;
  for (const glm::uvec3& t : mesh.triangles) {
    glm::dvec3 a, b, c;
    corners(t, a, b, c);
    const double m = subdivisions(longest_edge(a, b, c));
    if (glm::length(glm::cross(b - a, c - a)) > 0.0) total += m * m;
  }
  if (!(total <= static_cast<double>(options.max_gaussians)))
    throw std::invalid_argument("mesh_surface_gaussians: " + std::to_string(static_cast<long long>(total)) +
                                " Gaussians at a spacing of " + std::to_string(options.spacing) + " m, more than " +
                                std::to_string(options.max_gaussians));
  out.positions.reserve(static_cast<size_t>(total));

  for (const glm::uvec3& t : mesh.triangles) {
    glm::dvec3 a, b, c;
    corners(t, a, b, c);
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    const double twice_area = glm::length(cr);
    if (!(twice_area > 0.0)) continue;
    const glm::dvec3 n = cr / twice_area;
    const glm::dvec3 u = glm::normalize(b - a);
    const glm::dmat3 frame(u, glm::cross(n, u), n);  // columns: in-plane x, in-plane y, normal
    const glm::vec4 q_wxyz(quaternion_from_rotation(frame));  // (w, x, y, z) in x..w

    const double centroid_z = (a.z + b.z + c.z) / 3.0 - z_min;
    glm::vec3 rgb = paint.body;
    if (centroid_z < paint.tire_height) rgb = paint.tire;
    else if (centroid_z > paint.belt_height && std::fabs(n.z) < 0.9) rgb = paint.glass;
    const float shade = paint.ambient + (1.0f - paint.ambient) * static_cast<float>(std::max(0.0, glm::dot(n, sun)));
    float sh0[3];
    for (int k = 0; k < 3; ++k)
      sh0[k] = static_cast<float>((static_cast<double>(std::clamp(rgb[k] * shade, 0.0f, 1.0f)) - 0.5) / kShC0);

    const double longest = longest_edge(a, b, c);
    const int m = static_cast<int>(subdivisions(longest));
    const float sigma = static_cast<float>(0.5 * longest / m);
    const glm::vec3 scale(sigma, sigma, static_cast<float>(options.normal_sigma));
    // Sub-triangles of the m x m split in barycentric steps (i, j): "up" ones with corners
    // (i, j), (i+1, j), (i, j+1) and "down" ones (i+1, j), (i+1, j+1), (i, j+1), for i + j < m.
    const glm::dvec3 du = (b - a) / static_cast<double>(m), dv = (c - a) / static_cast<double>(m);
    for (int i = 0; i < m; ++i)
      for (int j = 0; i + j < m; ++j) {
        const glm::dvec3 base = a + static_cast<double>(i) * du + static_cast<double>(j) * dv;
        out.add(base + (du + dv) / 3.0, scale, q_wxyz, paint.opacity, sh0);
        if (i + j + 1 < m) out.add(base + 2.0 * (du + dv) / 3.0, scale, q_wxyz, paint.opacity, sh0);
      }
  }
  return out;
}

}  // namespace icube::splat
