// BatchNorm in inference form (running statistics), as the GSM's conv image
// encoder and Depth-Anything upsampler use it: y = (x - mean) / sqrt(var + eps)
// * weight + bias per channel (axis 1), any spatial rank.
// GPU: BatchNorm::record (shaders/nn/batch_norm.comp) applies it as the
// per-channel affine y = act(x * scale[c] + shift[c]), scale and shift folded
// once on the host in double (batch_norm_affine), optionally fused with ReLU
// or SiLU (the encoder's BN+ReLU and BN+SiLU). In place is allowed (x and y
// the same buffer: every element is read and written by one thread only).
// Tensors beyond one storage binding run as flat windows of elements. No
// barrier inside.
// CPU reference: nn::cpu::batch_norm (batch_norm_cpu.cpp). Tests: tests/nn/test_batch_norm.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

enum class BatchNormActivation : uint32_t { none = 0, relu = 1, silu = 2 };

// scale = weight / sqrt(var + eps), shift = bias - mean * scale, in double, rounded to float once.
struct BatchNormAffine {
  std::vector<float> scale, shift;
};
BatchNormAffine batch_norm_affine(const std::vector<float>& weight, const std::vector<float>& bias,
                                  const std::vector<float>& running_mean, const std::vector<float>& running_var,
                                  double eps = 1e-5);

struct BatchNormShape {
  uint32_t batch = 1;
  uint32_t channels = 1;
  uint64_t spatial = 1;  // elements per (batch, channel): the product of the axes after the channel axis
};

class BatchNorm {
 public:
  explicit BatchNorm(gpu::Context& ctx);
  // y = act(x * scale[c] + shift[c]) over x [batch, channels, spatial]; scale and shift hold `channels`
  // floats (batch_norm_affine). y may be x itself (in place). The caller orders the inputs before and y after.
  void record(gpu::CommandList& cmd, const BatchNormShape& s, const gpu::Buffer& x, const gpu::Buffer& scale,
              const gpu::Buffer& shift, const gpu::Buffer& y, BatchNormActivation act = BatchNormActivation::none);
  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit), to exercise the windows cheaply.
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

CpuTensor batch_norm(const CpuTensor& x, const CpuTensor& weight, const CpuTensor& bias, const CpuTensor& running_mean,
                     const CpuTensor& running_var, double eps = 1e-5);

}  // namespace icube::nn::cpu
