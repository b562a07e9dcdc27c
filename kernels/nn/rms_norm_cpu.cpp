// Plain-loop CPU reference of x-unet's RMSNorm; see nn/rms_norm.h (double).
#include "kernels/nn/rms_norm.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

CpuTensor rms_norm(const CpuTensor& x, const CpuTensor& gamma, double eps) {
  require(x.rank() >= 2, "rms_norm: input " + x.shape_text() + " is not [B, C, ...]");
  const int64_t B = x.dim(0), C = x.dim(1), S = detail::spatial_of(x);
  require(gamma.numel() == C, "rms_norm: gamma " + gamma.shape_text() + " does not have " + std::to_string(C) + " values");
  const double scale = std::sqrt(static_cast<double>(C));
  CpuTensor y(x.shape);
  for (int64_t b = 0; b < B; ++b)
    for (int64_t s = 0; s < S; ++s) {
      const float* in = x.data.data() + b * C * S + s;
      float* out = y.data.data() + b * C * S + s;
      double sq = 0.0;
      for (int64_t c = 0; c < C; ++c) sq += D(in[c * S]) * D(in[c * S]);
      const double inv = scale / std::max(std::sqrt(sq), eps);
      for (int64_t c = 0; c < C; ++c) out[c * S] = static_cast<float>(D(in[c * S]) * inv * D(gamma.data[static_cast<size_t>(c)]));
    }
  return y;
}

}  // namespace icube::nn::cpu
