// The per-frame constants of a splatting frame; see splat_frame.h.
#include "splat/splat_frame.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

namespace icube::splat {

SplatFrame make_frame(const render::Camera& cam, const SplatOptions& opts, const glm::dvec3& origin) {
  render::validate_camera(cam);
  if (opts.depth_key_bits != 32 && opts.depth_key_bits != 16)
    throw std::invalid_argument("splat: depth_key_bits must be 32 or 16, not " + std::to_string(opts.depth_key_bits));
  if (!(opts.near_z > 0.0) || !(opts.far_z > opts.near_z) || !std::isfinite(opts.near_z))
    throw std::invalid_argument("splat: need 0 < near < far");
  if (!(opts.eps2d >= 0.0f)) throw std::invalid_argument("splat: eps2d must be >= 0");
  SplatFrame f;
  const auto& K = cam.K;
  f.grid_x = (K.width + SPLAT_TILE - 1) / SPLAT_TILE;
  f.grid_y = (K.height + SPLAT_TILE - 1) / SPLAT_TILE;
  f.camera = glm::dvec3(cam.c2w[3]);
  const glm::dvec3 rel = f.camera - origin;
  auto& p = f.pre;
  // Rows of the world-to-camera rotation = columns of the camera-to-world rotation.
  float* r[9] = {&p.r00, &p.r01, &p.r02, &p.r10, &p.r11, &p.r12, &p.r20, &p.r21, &p.r22};
  for (int row = 0; row < 3; ++row)
    for (int c = 0; c < 3; ++c) *r[3 * row + c] = static_cast<float>(cam.c2w[row][c]);
  p.cam_x = static_cast<float>(rel.x);
  p.cam_y = static_cast<float>(rel.y);
  p.cam_z = static_cast<float>(rel.z);
  p.fx = static_cast<float>(K.fx);
  p.fy = static_cast<float>(K.fy);
  p.cx = static_cast<float>(K.cx);
  p.cy = static_cast<float>(K.cy);
  const render::PinholeIntrinsics& C = K;
  const double tan_x = 0.5 * C.width / C.fx, tan_y = 0.5 * C.height / C.fy;
  p.lim_x_pos = static_cast<float>((C.width - C.cx) / C.fx + 0.3 * tan_x);
  p.lim_x_neg = static_cast<float>(C.cx / C.fx + 0.3 * tan_x);
  p.lim_y_pos = static_cast<float>((C.height - C.cy) / C.fy + 0.3 * tan_y);
  p.lim_y_neg = static_cast<float>(C.cy / C.fy + 0.3 * tan_y);
  p.near_z = static_cast<float>(opts.near_z);
  p.far_z = static_cast<float>(std::min(opts.far_z, 3.0e38));
  p.eps2d = opts.eps2d;
  p.antialiased = opts.antialiased ? 1u : 0u;
  p.depth_key16 = opts.depth_key_bits == 16 ? 1u : 0u;
  p.width = K.width;
  p.tile_y0 = 0;
  p.grid_x = f.grid_x;
  p.grid_y = f.grid_y;
  return f;
}

void restrict_to_band(SplatFrame& f, uint32_t tile_y0, uint32_t rows) {
  if (rows == 0 || tile_y0 + uint64_t{rows} > f.grid_y)
    throw std::invalid_argument("splat: band of tile rows [" + std::to_string(tile_y0) + ", +" + std::to_string(rows) +
                                ") outside the image's " + std::to_string(f.grid_y));
  f.tile_y0 = f.pre.tile_y0 = tile_y0;
  f.grid_y = f.pre.grid_y = rows;
}

uint32_t depth_key16(float z) {
  uint32_t bits;
  std::memcpy(&bits, &z, 4);
  const int64_t k = int64_t{static_cast<int32_t>(bits >> 12)} - SPLAT_DEPTH_KEY16_OFFSET;
  return static_cast<uint32_t>(std::clamp<int64_t>(k, 0, 65535));
}

uint32_t depth_sort_key(float z, uint32_t bits) {
  if (bits == 16) return depth_key16(z);
  uint32_t b;
  std::memcpy(&b, &z, 4);
  return b;
}

}  // namespace icube::splat
