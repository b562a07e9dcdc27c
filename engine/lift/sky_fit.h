// The sky of a lifted scene: an equirectangular panorama (splat/sky.h's
// Equirect convention: row 0 the zenith, longitude 0 at the centre column
// looking along +x) fitted from the sky pixels of the appearance frames.
// Each sky pixel's world ray direction adds its RGB to the texel it falls in
// (integer sums: the same for any frame order); texels no pixel reached take
// the mean of their row's filled texels, rows with none the nearest filled
// row (the zenith and the ground half are rarely seen from a car), and an
// image with no sky pixel at all is the mean sky-blue of the conventions'
// gradient. The renderer composites Gaussians + T·sky(d).
// Tests: tests/lift/test_static_lift.cpp.
#pragma once

#include "render/camera.h"
#include "splat/sky.h"

#include <cstdint>
#include <vector>

namespace icube::lift {

class SkyFitter {
 public:
  SkyFitter(uint32_t width = 256, uint32_t height = 128);
  // `sky` W·H (nonzero = sky), `rgb` W·H·3 of `cam`'s frame.
  size_t add_frame(const render::Camera& cam, render::PixelConvention pixels, const std::vector<uint8_t>& rgb,
                   const std::vector<uint8_t>& sky);
  void add(const glm::dvec3& dir, uint8_t r, uint8_t g, uint8_t b);
  size_t samples() const { return samples_; }
  splat::SkyImage image() const;

 private:
  uint32_t w_, h_;
  size_t samples_ = 0;
  std::vector<uint64_t> sum_;  // 4 per texel: r, g, b, count
};

}  // namespace icube::lift
