// Plain-loop CPU references of LayerNorm; see nn/layer_norm.h (double accumulation).
#include "kernels/nn/layer_norm.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

CpuTensor layer_norm(const CpuTensor& x, const CpuTensor& weight, const CpuTensor& bias, double eps) {
  const int64_t D_ = x.shape.back(), rows = x.numel() / D_;
  require(weight.numel() == D_ && bias.numel() == D_, "layer_norm: parameters do not have " + std::to_string(D_) + " entries");
  CpuTensor y(x.shape);
  for (int64_t r = 0; r < rows; ++r) {
    const float* p = &x.data[static_cast<size_t>(r * D_)];
    double mean = 0.0, var = 0.0;
    for (int64_t i = 0; i < D_; ++i) mean += D(p[i]);
    mean /= static_cast<double>(D_);
    for (int64_t i = 0; i < D_; ++i) var += (D(p[i]) - mean) * (D(p[i]) - mean);
    var /= static_cast<double>(D_);
    const double inv = 1.0 / std::sqrt(var + eps);
    for (int64_t i = 0; i < D_; ++i)
      y.data[static_cast<size_t>(r * D_ + i)] =
          static_cast<float>((D(p[i]) - mean) * inv * D(weight.data[static_cast<size_t>(i)]) + D(bias.data[static_cast<size_t>(i)]));
  }
  return y;
}

}  // namespace icube::nn::cpu
