// Codec error of a decoded video frame against its lossless reference, for
// the mp4 tests (tests/video/test_mp4.cpp, tests/render/test_guidance_buffers_render.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace icube::test {

struct CodecError {
  double mean_abs = 0.0, psnr_db = 0.0;
  double bias[3] = {0.0, 0.0, 0.0};  // mean signed error per channel (a wrong colour matrix shows here)
  double interior_within = 1.0;  // fraction of flat-interior pixels decoded within kInteriorLevels on every channel
  double worst_bias() const { return std::max({std::abs(bias[0]), std::abs(bias[1]), std::abs(bias[2])}); }
};
inline constexpr int kInteriorLevels = 8;
inline constexpr uint32_t kInteriorRadius = 4;  // flat 9x9 neighbourhood: beyond 4:2:0 chroma and most 8x8 DCT ringing

// Error of `decoded` (dw wide, maybe padded) against `ref` (w x h) over the w x h region.
// Most of the loss sits on sharp colour edges (4:2:0 chroma mixes both sides
// of an edge); interior pixels, whose 9x9 neighbourhood in `ref` is one colour,
// see quantisation only.
inline CodecError codec_error(const std::vector<uint8_t>& ref, uint32_t w, uint32_t h, const std::vector<uint8_t>& decoded,
                       uint32_t dw) {
  double abs_sum = 0.0, sq_sum = 0.0, signed_sum[3] = {0.0, 0.0, 0.0};
  size_t interior = 0, within = 0;
  const uint32_t r = kInteriorRadius;
  auto at = [&](uint32_t x, uint32_t y, int c) { return ref[(size_t{y} * w + x) * 3 + static_cast<size_t>(c)]; };
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      int worst = 0;
      for (int c = 0; c < 3; ++c) {
        const int d = int{at(x, y, c)} - int{decoded[(size_t{y} * dw + x) * 3 + static_cast<size_t>(c)]};
        abs_sum += std::abs(d);
        signed_sum[c] -= d;
        sq_sum += double(d) * d;
        worst = std::max(worst, std::abs(d));
      }
      if (x < r || y < r || x + r >= w || y + r >= h) continue;
      bool flat = true;
      for (uint32_t yy = y - r; flat && yy <= y + r; ++yy)
        for (uint32_t xx = x - r; flat && xx <= x + r; ++xx)
          for (int c = 0; c < 3; ++c) flat = flat && at(xx, yy, c) == at(x, y, c);
      if (!flat) continue;
      ++interior;
      within += worst <= kInteriorLevels;
    }
  const double n = 3.0 * w * h;
  CodecError e;
  e.mean_abs = abs_sum / n;
  e.psnr_db = 10.0 * std::log10(255.0 * 255.0 / std::max(sq_sum / n, 1e-12));
  for (int c = 0; c < 3; ++c) e.bias[c] = signed_sum[c] / (n / 3.0);
  e.interior_within = interior ? double(within) / double(interior) : 1.0;
  return e;
}

}  // namespace icube::test
