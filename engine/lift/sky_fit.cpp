// Equirectangular sky fit; see sky_fit.h.
#include "lift/sky_fit.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace icube::lift {

SkyFitter::SkyFitter(uint32_t width, uint32_t height) : w_(width), h_(height), sum_(size_t(width) * height * 4, 0) {
  if (width == 0 || height == 0) throw std::invalid_argument("SkyFitter: empty panorama");
}

void SkyFitter::add(const glm::dvec3& d, uint8_t r, uint8_t g, uint8_t b) {
  const double kPi = 3.14159265358979323846;
  const double lon = std::atan2(d.y, d.x);
  const double theta = std::atan2(std::sqrt(d.x * d.x + d.y * d.y), d.z);
  double s = (0.5 - lon / (2.0 * kPi)) * double(w_), t = theta / kPi * double(h_);
  const uint32_t x = static_cast<uint32_t>(std::clamp(std::floor(s), 0.0, double(w_ - 1)));
  const uint32_t y = static_cast<uint32_t>(std::clamp(std::floor(t), 0.0, double(h_ - 1)));
  uint64_t* p = &sum_[(size_t(y) * w_ + x) * 4];
  p[0] += r, p[1] += g, p[2] += b, p[3] += 1;
  ++samples_;
}

size_t SkyFitter::add_frame(const render::Camera& cam, render::PixelConvention pixels, const std::vector<uint8_t>& rgb,
                            const std::vector<uint8_t>& sky) {
  const size_t W = cam.K.width, H = cam.K.height;
  if (rgb.size() != W * H * 3 || sky.size() != W * H)
    throw std::invalid_argument("SkyFitter::add_frame: image sizes disagree with the camera");
  const size_t before = samples_;
  for (size_t v = 0; v < H; ++v)
    for (size_t u = 0; u < W; ++u) {
      const size_t i = v * W + u;
      if (sky[i] == 0) continue;
      add(render::camera_ray(cam, uint32_t(u), uint32_t(v), pixels).dir, rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
    }
  return samples_ - before;
}

splat::SkyImage SkyFitter::image() const {
  splat::SkyImage img;
  img.width = w_;
  img.height = h_;
  img.rgba.assign(size_t(w_) * h_ * 4, 255);
  // Row means over filled texels (texel means averaged), -1 where a row has none.
  std::vector<glm::dvec3> row_mean(h_, glm::dvec3(-1.0));
  for (uint32_t y = 0; y < h_; ++y) {
    glm::dvec3 acc(0.0);
    uint32_t n = 0;
    for (uint32_t x = 0; x < w_; ++x) {
      const uint64_t* p = &sum_[(size_t(y) * w_ + x) * 4];
      if (p[3] == 0) continue;
      acc += glm::dvec3(double(p[0]), double(p[1]), double(p[2])) / double(p[3]);
      ++n;
    }
    if (n > 0) row_mean[y] = acc / double(n);
  }
  // Rows with no texel take the nearest filled row (the upper one on a tie).
  const splat::SkyGradient grad;
  const glm::dvec3 fallback = 127.5 * glm::dvec3(grad.zenith + grad.horizon);
  std::vector<glm::dvec3> row_fill(h_, fallback);
  for (uint32_t y = 0; y < h_; ++y) {
    for (uint32_t dist = 0; dist < h_; ++dist) {
      if (y >= dist && row_mean[y - dist].x >= 0.0) { row_fill[y] = row_mean[y - dist]; break; }
      if (y + dist < h_ && row_mean[y + dist].x >= 0.0) { row_fill[y] = row_mean[y + dist]; break; }
    }
  }
  for (uint32_t y = 0; y < h_; ++y)
    for (uint32_t x = 0; x < w_; ++x) {
      const uint64_t* p = &sum_[(size_t(y) * w_ + x) * 4];
      const glm::dvec3 c = p[3] > 0 ? glm::dvec3(double(p[0]), double(p[1]), double(p[2])) / double(p[3]) : row_fill[y];
      uint8_t* o = &img.rgba[(size_t(y) * w_ + x) * 4];
      for (int k = 0; k < 3; ++k) o[k] = static_cast<uint8_t>(std::clamp(std::lround(c[k]), 0l, 255l));
    }
  return img;
}

}  // namespace icube::lift
