// A plain host tensor for the CPU references of the network layer: float32
// values in C order with a shape (NCDHW for 3-D feature maps, row-major for
// matrices). No strides, no views: the references favour obviousness. Each
// layer's plain-loop CPU reference (namespace nn::cpu) is declared in its
// kernel's header (kernels/nn/<op>.h) and defined in <op>_cpu.cpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace icube::nn {

// "[2, 3, 4]": a tensor shape as messages show it.
inline std::string shape_text(const std::vector<int64_t>& shape) {
  std::string s = "[";
  for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + "]";
}

struct CpuTensor {
  std::vector<int64_t> shape;
  std::vector<float> data;

  CpuTensor() = default;
  explicit CpuTensor(std::vector<int64_t> s, float fill = 0.0f) : shape(std::move(s)) {
    data.assign(static_cast<size_t>(count(shape)), fill);
  }
  CpuTensor(std::vector<int64_t> s, std::vector<float> values) : shape(std::move(s)), data(std::move(values)) {
    if (static_cast<int64_t>(data.size()) != count(shape)) throw std::invalid_argument("CpuTensor: shape does not match values");
  }

  static int64_t count(const std::vector<int64_t>& s) {
    int64_t n = 1;
    for (int64_t d : s) n *= d;
    return n;
  }
  int64_t numel() const { return count(shape); }
  int64_t dim(size_t i) const { return shape.at(i); }
  size_t rank() const { return shape.size(); }
  // Elements per item of the first axis (a batch element).
  int64_t per_item() const { return shape.empty() ? 1 : numel() / shape[0]; }
  std::string shape_text() const { return nn::shape_text(shape); }
};

namespace cpu {

// [a | b] along the channel axis (axis 1); the other axes equal.
CpuTensor concat_channels(const CpuTensor& a, const CpuTensor& b);
// The project's agreement metric for networks: max |got - ref| / std(ref) (population std, in double);
// +infinity where a NaN or infinity on either side is not matched exactly by the other (so no tolerance
// passes it). Test: tests/nn/test_agreement_metric.cpp.
double max_abs_over_std(const std::vector<float>& got, const std::vector<float>& ref);

// Small helpers of the CPU references (kernels/nn/*_cpu.cpp).
namespace detail {
inline double D(float v) { return static_cast<double>(v); }
inline void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}
// Elements per (batch, channel) plane: the product of the axes after the first two.
inline int64_t spatial_of(const CpuTensor& x) {
  int64_t n = 1;
  for (size_t i = 2; i < x.rank(); ++i) n *= x.shape[i];
  return n;
}
}  // namespace detail

}  // namespace cpu

}  // namespace icube::nn
