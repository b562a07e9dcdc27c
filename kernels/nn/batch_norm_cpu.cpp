// Plain-loop CPU reference of inference BatchNorm; see nn/batch_norm.h.
#include "kernels/nn/batch_norm.h"

#include <cmath>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

CpuTensor batch_norm(const CpuTensor& x, const CpuTensor& weight, const CpuTensor& bias, const CpuTensor& running_mean,
                     const CpuTensor& running_var, double eps) {
  require(x.rank() >= 2, "batch_norm: input " + x.shape_text() + " has no channel axis");
  const int64_t B = x.dim(0), C = x.dim(1), S = detail::spatial_of(x);
  for (const CpuTensor* p : {&weight, &bias, &running_mean, &running_var})
    require(p->numel() == C, "batch_norm: a parameter does not have " + std::to_string(C) + " values");
  CpuTensor y(x.shape);
  for (int64_t c = 0; c < C; ++c) {
    const double inv = 1.0 / std::sqrt(D(running_var.data[static_cast<size_t>(c)]) + eps);
    const double scale = D(weight.data[static_cast<size_t>(c)]) * inv;
    const double shift = D(bias.data[static_cast<size_t>(c)]) - D(running_mean.data[static_cast<size_t>(c)]) * scale;
    for (int64_t b = 0; b < B; ++b)
      for (int64_t s = 0; s < S; ++s) {
        const size_t i = static_cast<size_t>((b * C + c) * S + s);
        y.data[i] = static_cast<float>(D(x.data[i]) * scale + shift);
      }
  }
  return y;
}

}  // namespace icube::nn::cpu
