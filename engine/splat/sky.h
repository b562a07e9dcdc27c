// Sky models for the Gaussian splatting rasterizer: the colour seen where a
// pixel's ray passes through the Gaussians, composited as C + T·sky(d) with
// T the pixel's final transmittance (rasterizer_cpu.h; GPU: splat/blend.comp).
//
// d is the unit world-space direction of the pixel's ray,
//   d = normalize(M · (u + o, v + o, 1)),  M = R_c2w · K⁻¹ (render::camera_ray_matrix, in float).
// The world is z-up (project convention), so "up" is d.z.
// - Background: the constant SplatOptions::background (the default).
// - Gradient: h = d.z; h ≥ 0: horizon + (zenith − horizon)·h; h < 0:
//   horizon + (ground − horizon)·(−h) (linear in the up component).
// - Equirect: an RGBA8 image (alpha ignored, values / 255, no gamma
//   conversion), longitude λ = atan2(d.y, d.x) (0 on +x, +π/2 on +y),
//   polar angle θ = atan2(√(d.x² + d.y²), d.z) (0 straight up);
//   image coordinates s = (0.5 − λ/2π)·W, t = (θ/π)·H, so row 0 is the zenith,
//   the centre column looks along +x and the image reads left to right when
//   turning clockwise seen from above (a panorama photo, not mirrored).
//   Bilinear between texel centres (x = s − 0.5, y = t − 0.5), wrapping in
//   longitude, clamped at the poles.
// Tests: tests/splat/test_splat.cpp ("splat sky ...").
#pragma once

#include "render/camera.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace icube::splat {

enum class SkyKind : uint32_t { Background = 0, Gradient = 1, Equirect = 2 };

struct SkyGradient {
  glm::vec3 zenith{0.22f, 0.42f, 0.78f};
  glm::vec3 horizon{0.78f, 0.84f, 0.90f};
  glm::vec3 ground{0.32f, 0.30f, 0.27f};
};

struct SkyImage {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // 4 bytes per texel, row-major, row 0 = zenith
};

struct SkyModel {
  SkyKind kind = SkyKind::Background;
  SkyGradient gradient;
  std::shared_ptr<const SkyImage> image;  // Equirect only
};

SkyModel sky_gradient(const SkyGradient& g = {});
SkyModel sky_equirect(std::shared_ptr<const SkyImage> image);

// Decodes a PNG (any channel count, 8 or 16 bit; converted to RGBA8). Throws
// std::runtime_error "PATH: reason" for an unreadable or empty file.
SkyImage read_sky_png(const std::string& path);
// "background", "gradient" or the path of an equirectangular .png (the CLI's --sky).
SkyModel parse_sky(const std::string& spec);

// Throws std::invalid_argument for an Equirect model without a valid image.
void validate_sky(const SkyModel& sky);

// M = R_c2w · K⁻¹ in double, rounded to float, row-major.
void sky_ray_matrix(const render::Camera& cam, float m[9]);
// World ray direction of the pixel sample (px, py) = (u + o, v + o), in float:
// m = M row-major (9 floats). Same operations as splat/blend.comp.
glm::vec3 sky_ray_dir(const float m[9], float px, float py);
// Sky colour for unit world direction `d` (`background` for SkyKind::Background).
glm::vec3 sky_color(const SkyModel& sky, const glm::vec3& background, const glm::vec3& d);

}  // namespace icube::splat
