// Ray-cast hits to guidance buffers and their encoders; see guidance_frame.h.
#include "render/buffers/guidance_frame.h"

#include "world/semantics.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace icube::render {

GuidanceFrame frame_from_hits(const std::vector<shader::RaycastHit>& hits, const PinholeIntrinsics& K,
                              PixelConvention pixels) {
  const size_t n = static_cast<size_t>(K.width) * K.height;
  if (hits.size() != n) throw std::invalid_argument("frame_from_hits: hit count differs from the image size");
  GuidanceFrame f;
  f.width = K.width;
  f.height = K.height;
  f.zdepth.assign(n, 0.0f);
  f.classes.assign(n, 0);
  f.instance.assign(n, 0);
  f.normal.assign(n, 0);
  // z-depth = t * ray_z in float32, as upstream (camera/pinhole.py: rays =
  // K^-1 [u, v, 1] / |K^-1 [u, v, 1]| in float32, distance_to_zdepth multiplies).
  const float o = static_cast<float>(pixel_offset(pixels));
  const float ifx = 1.0f / static_cast<float>(K.fx), ify = 1.0f / static_cast<float>(K.fy);
  const float ocx = -static_cast<float>(K.cx) * ifx, ocy = -static_cast<float>(K.cy) * ify;
  for (uint32_t v = 0; v < K.height; ++v) {
    const float y = ify * (static_cast<float>(v) + o) + ocy;
    for (uint32_t u = 0; u < K.width; ++u) {
      const size_t i = static_cast<size_t>(v) * K.width + u;
      const shader::RaycastHit& h = hits[i];
      if (h.flags & RAYCAST_FLAG_DEPTH) {
        const float x = ifx * (static_cast<float>(u) + o) + ocx;
        const float ray_z = 1.0f / std::sqrt(x * x + y * y + 1.0f);
        f.zdepth[i] = h.t_depth * ray_z;
      }
      if (h.flags & RAYCAST_FLAG_SEM) {
        f.classes[i] = static_cast<uint8_t>(h.sem_class);
        f.instance[i] = static_cast<uint16_t>(h.sem_instance);
        f.normal[i] = static_cast<int8_t>(h.normal);
      }
    }
  }
  return f;
}

std::vector<uint16_t> depth_centimetres(const std::vector<float>& zdepth) {
  std::vector<uint16_t> out(zdepth.size(), 0);
  for (size_t i = 0; i < zdepth.size(); ++i) {
    // float32 product, then truncation: numpy's (depth * 100).astype(np.uint16) on float32 depth.
    const float cm = std::trunc(zdepth[i] * 100.0f);
    out[i] = cm >= 65535.0f ? uint16_t{65535} : cm > 0.0f ? static_cast<uint16_t>(cm) : uint16_t{0};
  }
  return out;
}

std::vector<uint8_t> semantic_rgb(const GuidanceFrame& f, const std::map<uint16_t, Rgb8>& colors) {
  std::vector<uint8_t> out(f.classes.size() * 3);
  for (size_t i = 0; i < f.classes.size(); ++i) {
    Rgb8 c = world::class_color(f.classes[i]);
    if (f.instance[i] > 0) {
      const auto it = colors.find(f.instance[i]);
      if (it != colors.end()) c = it->second;
    }
    out[3 * i] = c[0];
    out[3 * i + 1] = c[1];
    out[3 * i + 2] = c[2];
  }
  return out;
}

std::vector<uint8_t> depth_vis_rgb(const std::vector<float>& zdepth, double max_metres) {
  // Ramp anchors (near -> far): yellow, orange, magenta, purple, dark blue.
  static constexpr double kRamp[5][3] = {{252, 231, 37}, {245, 135, 48}, {204, 71, 120}, {106, 0, 168}, {13, 8, 135}};
  std::vector<uint8_t> out(zdepth.size() * 3, 0);
  for (size_t i = 0; i < zdepth.size(); ++i) {
    if (!(zdepth[i] > 0.0f)) continue;
    const double s = std::clamp(static_cast<double>(zdepth[i]) / max_metres, 0.0, 1.0) * 4.0;
    const int k = std::min(3, static_cast<int>(s));
    const double w = s - k;
    for (int c = 0; c < 3; ++c)
      out[3 * i + static_cast<size_t>(c)] = static_cast<uint8_t>(kRamp[k][c] * (1.0 - w) + kRamp[k + 1][c] * w);
  }
  return out;
}

std::vector<uint8_t> normal_rgb(const GuidanceFrame& f) {
  std::vector<uint8_t> out(f.normal.size() * 3, 0);
  for (size_t i = 0; i < f.normal.size(); ++i) {
    const int n = f.normal[i];
    if (n == 0) continue;
    const int axis = std::abs(n) - 1;
    for (int c = 0; c < 3; ++c) out[3 * i + static_cast<size_t>(c)] = c == axis ? (n > 0 ? 255 : 0) : 127;
  }
  return out;
}

}  // namespace icube::render
