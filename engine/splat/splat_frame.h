// What one splatting frame is, shared by the CPU reference (rasterizer_cpu.h)
// and the GPU rasterizer (rasterizer_gpu.h): the options, the per-frame
// constants both derive from the camera (the GPU's preprocess push constants),
// and the image they return. Conventions: rasterizer_cpu.h.
// Tests: tests/splat/test_splat.cpp.
#pragma once

#include "render/camera.h"
#include "shared/splat_params.h"
#include "splat/sky.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::splat {

struct SplatOptions {
  double near_z = 0.01;
  double far_z = 1e10;
  float eps2d = 0.3f;
  bool antialiased = false;
  render::PixelConvention pixels = render::PixelConvention::Centre;
  glm::vec3 background{0.0f};
  SkyModel sky;  // default: the constant `background`
  // Expected and median depth (SplatImage::depth). false leaves them out: the GPU blend then
  // neither keeps nor writes them (a pipeline without them, ~15 % less blend time on
  // lavapipe), and SplatImage::depth is empty.
  bool depth = true;
  // Depth sort keys: 32 = the float bits of view z (the exact depth order); 16 = a log-linear
  // code of z (shared/splat_params.h: 2048 steps per octave over [2^-16, 2^16) m): half the
  // depth sort's radix passes, Gaussians within one step (relative depth 2^-11) keep index order.
  uint32_t depth_key_bits = 32;
};

// The 16-bit depth key of view depth z (see SplatOptions::depth_key_bits; 0 for z <= 2^-16).
uint32_t depth_key16(float z);
// The depth sort key of z under `bits` (32: float bits, 16: depth_key16).
uint32_t depth_sort_key(float z, uint32_t bits);

// Per-frame constants shared by the CPU reference and the GPU push constants.
struct SplatFrame {
  shader::SplatPreprocessParams pre{};  // n/first/sh_* left for the caller
  uint32_t grid_x = 0, grid_y = 0;
  glm::dvec3 camera{0.0};  // world position
};
// `origin`: the scene origin the GPU positions are relative to (the CPU reference passes 0 and
// uses double camera-relative positions instead).
// `clamp_image`: the image whose frustum the Jacobian clamp follows (default cam.K); a band of a
// larger image (SplatRendererGpu) passes the whole image's, so its Gaussians project as there.
SplatFrame make_frame(const render::Camera& cam, const SplatOptions& opts, const glm::dvec3& origin,
                      const render::PinholeIntrinsics* clamp_image = nullptr);

struct SplatImage {
  uint32_t width = 0, height = 0;
  std::vector<float> rgba;   // 4 per pixel, row-major: RGB (background composited) and alpha
  std::vector<float> depth;  // 2 per pixel: expected, median
};

}  // namespace icube::splat
