// fp16 tensors in the nn kernel tests: upload float values as fp16, download an
// fp16 output as floats, round a reference to fp16, and compare a kernel's fp16
// store with its fp32 reference rounded (round to nearest even).
#pragma once

#include "gpu/buffer.h"
#include "gpu_test_context.h"
#include "kernels/nn/float16.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

namespace icube::test {

inline std::vector<uint16_t> to_halves(const std::vector<float>& v) {
  std::vector<uint16_t> h(v.size());
  for (size_t i = 0; i < v.size(); ++i) h[i] = nn::float_to_half(v[i]);
  return h;
}

// A value as fp16 holds it (round to nearest even).
inline float round_to_half(float v) { return nn::half_to_float(nn::float_to_half(v)); }

// The values as fp16 would hold them.
inline std::vector<float> rounded_to_half(const std::vector<float>& v) {
  std::vector<float> r(v.size());
  for (size_t i = 0; i < v.size(); ++i) r[i] = round_to_half(v[i]);
  return r;
}

inline std::vector<float> download_halves(gpu::Context& ctx, const gpu::Buffer& buf, size_t count) {
  const std::vector<uint16_t> h = gpu::download_vector<uint16_t>(ctx, buf, count);
  std::vector<float> f(h.size());
  for (size_t i = 0; i < h.size(); ++i) f[i] = nn::half_to_float(h[i]);
  return f;
}

// A kernel's fp16 store of values the fp32 reference `want` approximates to `tol` (relative to each value,
// plus `tol` absolute): every element is one of the two fp16 values around want +- tol, and all but
// `max_flipped_fraction` equal want rounded to nearest even (the kernel's fp32 value and the reference
// may straddle a rounding boundary).
inline bool half_store_matches(const std::vector<float>& got, const std::vector<float>& want, double tol,
                               double max_flipped_fraction, const char* what) {
  if (got.size() != want.size()) return false;
  size_t flipped = 0, bad = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const float exact = round_to_half(want[i]);
    if (got[i] == exact) continue;
    ++flipped;
    const double w = want[i], margin = tol * (1.0 + std::fabs(w));
    const double lo = round_to_half(static_cast<float>(w - margin));
    const double hi = round_to_half(static_cast<float>(w + margin));
    const double g = got[i];
    // Within the fp16 neighbours of [w - margin, w + margin] (one fp16 step beyond each end at most).
    const double step = std::fabs(static_cast<double>(exact)) * (1.0 / 1024.0) + 6.0e-8;
    if (!(g >= lo - step && g <= hi + step)) {
      if (bad < 8)
        std::fprintf(stderr, "%s: element %zu is %.8g, fp16 of the reference %.8g is %.8g\n", what, i,
                     static_cast<double>(got[i]), w, static_cast<double>(exact));
      ++bad;
    }
  }
  const double fraction = got.empty() ? 0.0 : static_cast<double>(flipped) / static_cast<double>(got.size());
  if (fraction > max_flipped_fraction)
    std::fprintf(stderr, "%s: %zu of %zu fp16 values differ from the rounded reference (at most %.3g allowed)\n", what,
                 flipped, got.size(), max_flipped_fraction);
  return bad == 0 && fraction <= max_flipped_fraction;
}

}  // namespace icube::test
