// Shared helpers of the Gaussian splatting tests (random scenes, cameras, comparisons).
#pragma once

#include "splat/gaussians.h"
#include "splat/rasterizer_cpu.h"

#include <glm/glm.hpp>

#include <cmath>
#include <cstdint>
#include <random>

namespace icube::test {

// A camera at `eye` looking at `target` (OpenCV axes; world z up).
inline render::Camera look_at_camera(const glm::dvec3& eye, const glm::dvec3& target, uint32_t w, uint32_t h,
                                     double f, double cx_off = 0.0, double cy_off = 0.0) {
  const glm::dvec3 z = glm::normalize(target - eye);
  glm::dvec3 up(0.0, 0.0, 1.0);
  if (std::fabs(glm::dot(up, z)) > 0.99) up = glm::dvec3(0.0, 1.0, 0.0);
  const glm::dvec3 x = glm::normalize(glm::cross(z, up));  // right
  const glm::dvec3 y = glm::cross(z, x);                   // down
  render::Camera c;
  c.K = {f, f, 0.5 * w + cx_off, 0.5 * h + cy_off, w, h};
  c.c2w = glm::dmat4(glm::dvec4(x, 0.0), glm::dvec4(y, 0.0), glm::dvec4(z, 0.0), glm::dvec4(eye, 1.0));
  return c;
}

// n Gaussians in a box around `centre` with half-size `half`.
inline splat::GaussianCloud random_cloud(uint32_t seed, size_t n, uint32_t degree, const glm::dvec3& centre,
                                         double half, double log_scale_lo = -4.0, double log_scale_hi = -1.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  std::normal_distribution<double> nd(0.0, 1.0);
  splat::GaussianCloud c;
  c.sh_degree = degree;
  std::vector<float> coeffs(c.sh_coeffs() * 3);
  for (size_t i = 0; i < n; ++i) {
    const glm::dvec3 p = centre + half * glm::dvec3(u(rng), u(rng), u(rng));
    const glm::vec3 s(std::exp(log_scale_lo + (log_scale_hi - log_scale_lo) * u01(rng)),
                      std::exp(log_scale_lo + (log_scale_hi - log_scale_lo) * u01(rng)),
                      std::exp(log_scale_lo + (log_scale_hi - log_scale_lo) * u01(rng)));
    glm::dvec4 q(nd(rng), nd(rng), nd(rng), nd(rng));
    q /= glm::length(q);
    for (size_t k = 0; k < coeffs.size(); ++k) coeffs[k] = static_cast<float>((k < 3 ? 1.5 : 0.3) * u(rng));
    c.add(p, s, glm::vec4(q), static_cast<float>(u01(rng)), coeffs.data());
  }
  return c;
}

}  // namespace icube::test
