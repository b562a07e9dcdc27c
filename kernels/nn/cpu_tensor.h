// A plain host tensor for the CPU references of the network layer: float32
// values in C order with a shape (NCDHW for 3-D feature maps, row-major for
// matrices). No strides, no views: the references favour obviousness.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace icube::nn {

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
  std::string shape_text() const {
    std::string s = "[";
    for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
    return s + "]";
  }
};

}  // namespace icube::nn
