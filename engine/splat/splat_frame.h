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
  uint32_t grid_x = 0, grid_y = 0;      // grid_y: tile rows of the band (all rows: a whole image)
  uint32_t tile_y0 = 0;                 // the band's first tile row (0: a whole image)
  glm::dvec3 camera{0.0};  // world position
};
// `origin`: the scene origin the GPU positions are relative to (the CPU reference passes 0 and
// uses double camera-relative positions instead).
SplatFrame make_frame(const render::Camera& cam, const SplatOptions& opts, const glm::dvec3& origin);
// The frame restricted to the band of tile rows [tile_y0, tile_y0 + rows) of its image: every
// Gaussian projects as in the whole image (same camera, same clamp), its tile rect rows are
// clipped to the band and tile ids count from the band's first row, so the band's pixels are
// the whole image's, bit for bit.
void restrict_to_band(SplatFrame& f, uint32_t tile_y0, uint32_t rows);

struct SplatImage {
  uint32_t width = 0, height = 0;
  std::vector<float> rgba;   // 4 per pixel, row-major: RGB (background composited) and alpha
  std::vector<float> depth;  // 2 per pixel: expected, median
};

}  // namespace icube::splat
