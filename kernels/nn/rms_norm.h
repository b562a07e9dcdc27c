// x-unet 0.4.0's RMSNorm over the channels of [batch, channels, H, W] (the
// pixel branch's Block: 3x3 conv -> RMSNorm -> SiLU):
//   y = x / max(|x_pixel|_2, eps) * sqrt(channels) * gamma[c]   (F.normalize, eps 1e-12)
// optionally followed by SiLU in the same pass (RmsNormShape::silu).
// GPU: RmsNorm::record (shaders/nn/rms_norm.comp), one invocation per pixel
// looping over the channels (at most NN_RMS_MAX_CHANNELS = 20,000: lavapipe
// stops an invocation after 65,535 loop iterations; more channels are refused).
// The sum of squares is float32; a pixel whose sum overflows or falls below
// 1e-25 is summed again scaled by a power of two. A tensor beyond one storage
// binding runs in windows of whole batch elements, or of pixel ranges of one
// batch element (each binding spans (channels - 1) * H * W + the window's
// pixels); no barriers inside. y may be x (in place).
// CPU reference: nn::cpu::rms_norm (rms_norm_cpu.cpp, double).
// Tests: tests/nn/test_rms_norm.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>

namespace icube::kernels::nn {

struct RmsNormShape {
  uint32_t batch = 1, channels = 1;
  uint64_t plane = 1;   // H * W
  float eps = 1e-12f;   // x-unet's (F.normalize's default)
  bool silu = false;    // y = silu(norm(x)): x-unet's Block
};

class RmsNorm {
 public:
  explicit RmsNorm(gpu::Context& ctx);
  // gamma: `channels` floats (x-unet's [C, 1, 1, 1] parameter flattened).
  void record(gpu::CommandList& cmd, const RmsNormShape& s, const gpu::Buffer& x, const gpu::Buffer& gamma,
              const gpu::Buffer& y);
  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit), to exercise the windows cheaply.
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// x [B, C, ...] normalised over axis 1: x / max(|x|_2, eps) * sqrt(C) * gamma[c], gamma C values (any shape).
CpuTensor rms_norm(const CpuTensor& x, const CpuTensor& gamma, double eps = 1e-12);

}  // namespace icube::nn::cpu
