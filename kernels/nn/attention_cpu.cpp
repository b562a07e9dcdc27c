// Plain-loop CPU references of attention; see nn/attention.h (double accumulation).
#include "kernels/nn/attention.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

CpuTensor attention(const CpuTensor& q, const CpuTensor& k, const CpuTensor& v) {
  require(q.rank() == 4 && k.shape == q.shape && v.shape == q.shape, "attention: q, k, v must share one [B, H, N, D] shape");
  const int64_t BH = q.dim(0) * q.dim(1), N = q.dim(2), Dh = q.dim(3);
  const double scale = 1.0 / std::sqrt(static_cast<double>(Dh));
  CpuTensor out(q.shape);
  std::vector<double> logits(static_cast<size_t>(N));
  for (int64_t h = 0; h < BH; ++h) {
    const size_t base = static_cast<size_t>(h * N * Dh);
    for (int64_t i = 0; i < N; ++i) {
      double mx = -std::numeric_limits<double>::infinity();
      for (int64_t j = 0; j < N; ++j) {
        double dot = 0.0;
        for (int64_t d = 0; d < Dh; ++d)
          dot += D(q.data[base + static_cast<size_t>(i * Dh + d)]) * D(k.data[base + static_cast<size_t>(j * Dh + d)]);
        logits[static_cast<size_t>(j)] = dot * scale;
        mx = std::max(mx, logits[static_cast<size_t>(j)]);
      }
      double sum = 0.0;
      for (double& l : logits) sum += (l = std::exp(l - mx));
      for (int64_t d = 0; d < Dh; ++d) {
        double acc = 0.0;
        for (int64_t j = 0; j < N; ++j) acc += logits[static_cast<size_t>(j)] * D(v.data[base + static_cast<size_t>(j * Dh + d)]);
        out.data[base + static_cast<size_t>(i * Dh + d)] = static_cast<float>(acc / sum);
      }
    }
  }
  return out;
}

}  // namespace icube::nn::cpu
