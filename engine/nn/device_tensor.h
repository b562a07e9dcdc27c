// A network's tensor on the device: a buffer (pooled or borrowed) and its
// shape [B, C, spatial...], batch-major and channel-major inside a batch
// element, as the kernels/nn kernels read it. Sparse features are [1, C, rows].
#pragma once

#include "gpu/buffer.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace icube::nn {

struct DeviceTensor {
  std::shared_ptr<gpu::Buffer> buf;
  std::vector<int64_t> shape;
  // Elements stored as fp16: the convolutions' input operands under NetworkPrecision::F16
  // (LayerRecorder::set_f16_conv_operands); only the convolutions read such a tensor.
  bool f16 = false;

  int64_t batch() const { return shape[0]; }
  int64_t channels() const { return shape[1]; }
  int64_t spatial() const {
    int64_t s = 1;
    for (size_t i = 2; i < shape.size(); ++i) s *= shape[i];
    return s;
  }
  uint64_t numel() const { return static_cast<uint64_t>(batch() * channels() * spatial()); }
  uint64_t bytes() const { return numel() * (f16 ? 2 : 4); }

  // A view of a buffer the caller owns and keeps alive while the tensor is used.
  static DeviceTensor borrow(const gpu::Buffer& buffer, std::vector<int64_t> shape) {
    return {std::shared_ptr<gpu::Buffer>(const_cast<gpu::Buffer*>(&buffer), [](gpu::Buffer*) {}), std::move(shape), false};
  }
};

}  // namespace icube::nn
