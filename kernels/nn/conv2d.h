// 2-D convolutions of the GSM's image networks (the conv image encoder, the
// Depth-Anything neck and fusion, the sky patch embedding, x-unet's frame-1
// convolutions): PyTorch's Conv2d (any kernel, stride, zero padding, optional
// bias). The transposed convolution is kernels/nn/conv_transpose2d.h.
// GPU: Conv2d::record (shaders/nn/conv2d.comp, a register tile of 8 output
// channels x 4 output columns per invocation, the input as an R32_SFLOAT texel
// buffer). Weights are packed once on the host (pack_conv2d_weights) into
// [in_channels * kh * kw][out_channels padded to 8]. x and y may exceed one
// storage binding: record() then runs windows of one batch element, whole
// 8-channel output blocks and as many input channels as fit, later input
// windows accumulating into y after a compute-to-compute barrier inside
// record(); input channels also go in windows that keep an invocation under
// lavapipe's 65,535 loop iterations. The packed weights must fit one binding.
// CPU reference: nn::cpu::conv2d (conv2d_cpu.cpp, double accumulation). Tests: tests/nn/test_conv2d.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

struct Conv2dShape {
  uint32_t batch = 1, in_channels = 1, out_channels = 1;
  uint32_t height = 1, width = 1;  // input
  uint32_t kernel_h = 3, kernel_w = 3, stride = 1, padding = 1;
  uint32_t out_height() const;  // (H + 2p - kh) / s + 1 (0 when the kernel does not fit)
  uint32_t out_width() const;
};

// [Co, Ci, kh, kw] row-major -> [Ci * kh * kw][ceil(Co / 8) * 8] (zeros in the padding).
std::vector<float> pack_conv2d_weights(const std::vector<float>& w, uint32_t out_channels, uint32_t in_channels,
                                       uint32_t kernel_h, uint32_t kernel_w);

class Conv2d {
 public:
  explicit Conv2d(gpu::Context& ctx);
  // Records y = conv2d(x, w) + bias; `bias` may be nullptr. The caller orders x / weights before and y
  // after; the only barriers inside are those between input-channel windows.
  void record(gpu::CommandList& cmd, const Conv2dShape& s, const gpu::Buffer& x, const gpu::Buffer& packed_weights,
              const gpu::Buffer* bias, const gpu::Buffer& y);
  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit), to exercise the windows cheaply.
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// x [B, Ci, H, W], w [Co, Ci, kh, kw], bias [Co] or nullptr. Output [B, Co, (H + 2p - kh) / s + 1, (W + 2p - kw) / s + 1].
CpuTensor conv2d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride = 1, int padding = 0);

}  // namespace icube::nn::cpu
