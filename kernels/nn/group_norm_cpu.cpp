// Plain-loop CPU references of GroupNorm and its modulations; see nn/group_norm.h (double accumulation).
#include "kernels/nn/group_norm.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;
using detail::spatial_of;

CpuTensor group_norm(const CpuTensor& x, int groups, const CpuTensor& weight, const CpuTensor& bias, double eps) {
  const int64_t B = x.dim(0), C = x.dim(1), S = spatial_of(x);
  require(groups > 0 && C % groups == 0, "group_norm: " + std::to_string(C) + " channels in " +
                                             std::to_string(groups) + " groups");
  require(weight.numel() == C && bias.numel() == C, "group_norm: affine parameters do not have " + std::to_string(C) +
                                                        " entries");
  const int64_t cg = C / groups;
  CpuTensor y(x.shape);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t g = 0; g < groups; ++g) {
      const size_t base = static_cast<size_t>((b * C + g * cg) * S), n = static_cast<size_t>(cg * S);
      double mean = 0.0;
      for (size_t i = 0; i < n; ++i) mean += D(x.data[base + i]);
      mean /= static_cast<double>(n);
      double var = 0.0;
      for (size_t i = 0; i < n; ++i) var += (D(x.data[base + i]) - mean) * (D(x.data[base + i]) - mean);
      var /= static_cast<double>(n);
      const double inv = 1.0 / std::sqrt(var + eps);
      for (int64_t c = 0; c < cg; ++c) {
        const double wv = D(weight.data[static_cast<size_t>(g * cg + c)]), bv = D(bias.data[static_cast<size_t>(g * cg + c)]);
        for (int64_t s = 0; s < S; ++s) {
          const size_t i = base + static_cast<size_t>(c * S + s);
          y.data[i] = static_cast<float>((D(x.data[i]) - mean) * inv * wv + bv);
        }
      }
    }
  return y;
}

CpuTensor scale_shift(CpuTensor h, const CpuTensor& ss) {
  const int64_t B = h.dim(0), C = h.dim(1), S = spatial_of(h);
  require(ss.rank() == 2 && ss.dim(0) == B && ss.dim(1) == 2 * C, "scale_shift: modulation " + ss.shape_text() +
                                                                       " does not fit " + h.shape_text());
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < C; ++c) {
      const float scale = ss.data[static_cast<size_t>(b * 2 * C + c)], shift = ss.data[static_cast<size_t>(b * 2 * C + C + c)];
      float* p = &h.data[static_cast<size_t>((b * C + c) * S)];
      for (int64_t s = 0; s < S; ++s) p[s] = p[s] * (1.0f + scale) + shift;
    }
  return h;
}

CpuTensor add_channel_bias(CpuTensor h, const CpuTensor& e) {
  const int64_t B = h.dim(0), C = h.dim(1), S = spatial_of(h);
  require(e.rank() == 2 && e.dim(0) == B && e.dim(1) == C, "add_channel_bias: " + e.shape_text() + " does not fit " +
                                                               h.shape_text());
  for (int64_t b = 0; b < B; ++b)
    for (int64_t c = 0; c < C; ++c) {
      float* p = &h.data[static_cast<size_t>((b * C + c) * S)];
      for (int64_t s = 0; s < S; ++s) p[s] += e.data[static_cast<size_t>(b * C + c)];
    }
  return h;
}

}  // namespace icube::nn::cpu
