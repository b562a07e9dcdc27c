// The CPU tensor utilities; see cpu_tensor.h.
#include "kernels/nn/cpu_tensor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;
using detail::spatial_of;

CpuTensor concat_channels(const CpuTensor& a, const CpuTensor& b) {
  require(a.rank() == b.rank() && a.dim(0) == b.dim(0) && spatial_of(a) == spatial_of(b),
          "concat: " + a.shape_text() + " and " + b.shape_text() + " differ beyond the channels");
  const int64_t B = a.dim(0), Ca = a.dim(1), Cb = b.dim(1), S = spatial_of(a);
  std::vector<int64_t> shape = a.shape;
  shape[1] = Ca + Cb;
  CpuTensor y(shape);
  for (int64_t n = 0; n < B; ++n) {
    std::copy_n(&a.data[static_cast<size_t>(n * Ca * S)], Ca * S, &y.data[static_cast<size_t>(n * (Ca + Cb) * S)]);
    std::copy_n(&b.data[static_cast<size_t>(n * Cb * S)], Cb * S, &y.data[static_cast<size_t>((n * (Ca + Cb) + Ca) * S)]);
  }
  return y;
}

double max_abs_over_std(const std::vector<float>& got, const std::vector<float>& ref) {
  require(got.size() == ref.size() && !ref.empty(), "max_abs_over_std: sizes differ or are empty");
  double mean = 0.0, var = 0.0, mx = 0.0;
  for (float v : ref) mean += D(v);
  mean /= static_cast<double>(ref.size());
  for (float v : ref) var += (D(v) - mean) * (D(v) - mean);
  for (size_t i = 0; i < got.size(); ++i) {
    if (got[i] == ref[i]) continue;
    const double d = std::abs(D(got[i]) - D(ref[i]));
    // A NaN or an infinity on either side that the other does not match fails any tolerance (std::max
    // would skip a NaN).
    if (!(d <= std::numeric_limits<double>::max())) return std::numeric_limits<double>::infinity();
    mx = std::max(mx, d);
  }
  return mx / std::max(std::sqrt(var / static_cast<double>(ref.size())), 1e-30);
}

}  // namespace icube::nn::cpu
