// Plain-loop CPU references of the element-wise layers; see nn/elementwise.h (double accumulation).
#include "kernels/nn/elementwise.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

CpuTensor silu(CpuTensor x) {
  for (float& v : x.data) v = static_cast<float>(D(v) / (1.0 + std::exp(-D(v))));
  return x;
}

CpuTensor gelu(CpuTensor x) {
  for (float& v : x.data) v = static_cast<float>(0.5 * D(v) * (1.0 + std::erf(D(v) / std::sqrt(2.0))));
  return x;
}

CpuTensor relu(CpuTensor x) {
  for (float& v : x.data) v = v > 0.0f ? v : 0.0f;
  return x;
}

CpuTensor add(CpuTensor a, const CpuTensor& b) {
  require(a.shape == b.shape, "add: shapes " + a.shape_text() + " and " + b.shape_text() + " differ");
  for (size_t i = 0; i < a.data.size(); ++i) a.data[i] += b.data[i];
  return a;
}

}  // namespace icube::nn::cpu
