// Sky models of the splatting rasterizer; see sky.h. The float arithmetic
// follows shaders/splat/blend.comp (splat_sky) operation by operation.
#include "splat/sky.h"

#include "scene/png_read.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>


namespace icube::splat {

SkyModel sky_gradient(const SkyGradient& g) {
  SkyModel s;
  s.kind = SkyKind::Gradient;
  s.gradient = g;
  return s;
}

SkyModel sky_equirect(std::shared_ptr<const SkyImage> image) {
  SkyModel s;
  s.kind = SkyKind::Equirect;
  s.image = std::move(image);
  validate_sky(s);
  return s;
}

SkyImage read_sky_png(const std::string& path) {
  const scene::Image8 png = scene::read_png(path, 4);
  if (png.width <= 0 || png.height <= 0) throw std::runtime_error(path + ": empty image");
  SkyImage img;
  img.width = static_cast<uint32_t>(png.width);
  img.height = static_cast<uint32_t>(png.height);
  img.rgba = png.pixels;
  return img;
}

SkyModel parse_sky(const std::string& spec) {
  if (spec == "background" || spec.empty()) return SkyModel{};
  if (spec == "gradient") return sky_gradient();
  if (!std::filesystem::exists(spec))
    throw std::runtime_error("--sky: '" + spec + "' is neither 'background', 'gradient' nor an existing .png file");
  return sky_equirect(std::make_shared<const SkyImage>(read_sky_png(spec)));
}

void validate_sky(const SkyModel& sky) {
  if (sky.kind != SkyKind::Equirect) return;
  if (!sky.image || sky.image->width == 0 || sky.image->height == 0 ||
      sky.image->rgba.size() != size_t{sky.image->width} * sky.image->height * 4)
    throw std::invalid_argument("splat sky: equirect model needs a non-empty RGBA8 image");
}

void sky_ray_matrix(const render::Camera& cam, float m[9]) {
  const auto& K = cam.K;
  const double kinv[3][3] = {{1.0 / K.fx, 0.0, -K.cx / K.fx}, {0.0, 1.0 / K.fy, -K.cy / K.fy}, {0.0, 0.0, 1.0}};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      double v = 0.0;
      for (int k = 0; k < 3; ++k) v += cam.c2w[k][r] * kinv[k][c];  // R[r][k] = c2w column k, row r
      m[3 * r + c] = static_cast<float>(v);
    }
}

glm::vec3 sky_ray_dir(const float m[9], float px, float py) {
  const float x = m[0] * px + m[1] * py + m[2];
  const float y = m[3] * px + m[4] * py + m[5];
  const float z = m[6] * px + m[7] * py + m[8];
  const float inv = 1.0f / std::sqrt(x * x + y * y + z * z);
  return {x * inv, y * inv, z * inv};
}

namespace {
glm::vec3 texel(const SkyImage& img, int x, int y) {
  const uint8_t* t = &img.rgba[(size_t(y) * img.width + size_t(x)) * 4];
  return glm::vec3(float(t[0]) / 255.0f, float(t[1]) / 255.0f, float(t[2]) / 255.0f);
}
}  // namespace

glm::vec3 sky_color(const SkyModel& sky, const glm::vec3& background, const glm::vec3& d) {
  switch (sky.kind) {
    case SkyKind::Background:
      return background;
    case SkyKind::Gradient: {
      const SkyGradient& g = sky.gradient;
      const float h = d.z;
      if (h >= 0.0f) return g.horizon + (g.zenith - g.horizon) * h;
      return g.horizon + (g.ground - g.horizon) * (-h);
    }
    case SkyKind::Equirect: {
      const SkyImage& img = *sky.image;
      const float kPi = 3.14159265358979f;
      const float lon = std::atan2(d.y, d.x);
      const float theta = std::atan2(std::sqrt(d.x * d.x + d.y * d.y), d.z);
      const float x = (0.5f - lon / (2.0f * kPi)) * float(img.width) - 0.5f;
      const float y = (theta / kPi) * float(img.height) - 0.5f;
      const float xf = std::floor(x), yf = std::floor(y);
      const float ax = x - xf, ay = y - yf;
      const int W = int(img.width), H = int(img.height);
      const int xi = int(xf);  // in [-1, W - 1] for lon in [-π, π]
      const int x0 = xi < 0 ? xi + W : (xi >= W ? xi - W : xi), x1 = x0 + 1 == W ? 0 : x0 + 1;
      const int y0 = std::clamp(int(yf), 0, H - 1), y1 = std::clamp(int(yf) + 1, 0, H - 1);
      const glm::vec3 top = texel(img, x0, y0) * (1.0f - ax) + texel(img, x1, y0) * ax;
      const glm::vec3 bot = texel(img, x0, y1) * (1.0f - ax) + texel(img, x1, y1) * ax;
      return top * (1.0f - ay) + bot * ay;
    }
  }
  return background;
}

}  // namespace icube::splat
