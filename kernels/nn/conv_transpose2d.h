// PyTorch's ConvTranspose2d (weight [Ci, Co, kh, kw], any kernel, stride and
// padding, optional bias) for the GSM's image networks: Depth-Anything's
// reassemble up-projections (kernel = stride = 4 and 2) and x-unet's Upsample
// (kernel 4, stride 2, padding 1).
// GPU: ConvTranspose2d::record (shaders/nn/conv_transpose2d.comp) in gather
// form: output pixels are grouped by their phase (o + padding) mod stride per
// axis, which fixes the taps that reach them; an invocation holds 8 output
// channels x 4 output columns of one phase (stride apart, so their inputs are
// consecutive columns), the input an R32_SFLOAT texel buffer. Weights are
// packed once on the host (pack_conv_transpose2d_weights) into
// [in_channels * kh * kw][out_channels padded to 8]. Tensors (and packed
// weights) beyond one storage binding run as windows of one batch element,
// whole 8-channel output blocks and as many input channels as fit; input
// channels also go in windows that keep an invocation under lavapipe's 65,535
// loop iterations. Later input windows accumulate into y after a
// compute-to-compute barrier inside record() (the only barriers there).
// CPU reference: nn::cpu::conv_transpose2d (conv_transpose2d_cpu.cpp, double
// accumulation). Tests: tests/nn/test_conv_transpose2d.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

struct ConvTranspose2dShape {
  uint32_t batch = 1, in_channels = 1, out_channels = 1;
  uint32_t height = 1, width = 1;  // input
  uint32_t kernel_h = 4, kernel_w = 4, stride = 2, padding = 1;
  uint32_t out_height() const;  // (H - 1) s - 2p + kh (0 when that is not positive)
  uint32_t out_width() const;
};

// [Ci, Co, kh, kw] row-major (PyTorch's ConvTranspose2d layout) -> [Ci * kh * kw][ceil(Co / 8) * 8]
// (zeros in the padding).
std::vector<float> pack_conv_transpose2d_weights(const std::vector<float>& w, uint32_t in_channels, uint32_t out_channels,
                                                 uint32_t kernel_h, uint32_t kernel_w);

class ConvTranspose2d {
 public:
  explicit ConvTranspose2d(gpu::Context& ctx);
  // Records y = conv_transpose2d(x, w) + bias; `bias` may be nullptr. The caller orders x / weights before
  // and y after; the only barriers inside are those between input-channel windows.
  void record(gpu::CommandList& cmd, const ConvTranspose2dShape& s, const gpu::Buffer& x, const gpu::Buffer& packed_weights,
              const gpu::Buffer* bias, const gpu::Buffer& y);
  // Tests: pretend one binding holds at most `bytes` (0 = the device's limits), to exercise the windows cheaply.
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// ConvTranspose2d: x [B, Ci, H, W], w [Ci, Co, kh, kw] (PyTorch's layout), bias [Co] or nullptr.
// Output [B, Co, (H - 1) s - 2p + kh, (W - 1) s - 2p + kw].
CpuTensor conv_transpose2d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride, int padding = 0);

}  // namespace icube::nn::cpu
