// GroupNorm on the GPU with fp32 statistics (torch.nn.GroupNorm: biased
// variance, eps inside the square root, per-channel affine), optionally fused
// with the ResBlock scale-shift modulation h * (1 + scale) + shift and SiLU:
// three dispatches (shaders/nn/group_norm_partials, _stats, _apply) with the
// two barriers between them recorded inside record(); the caller orders x
// before and y after. Statistics are Welford partials over interleaved chunks
// of x minus the group's first element, combined with Chan's update, so a
// constant group normalises to exactly its bias and a large common offset
// costs no precision beyond x's own.
//
// x and y may exceed one storage binding: record() then runs windows of one
// batch element and as many whole groups as fit (each bound at its aligned
// offset, channel and batch offsets in the push constants), with a barrier
// between windows as they reuse the scratch. A single group larger than one
// binding (a full VAE chunk level: 16 channels x 2.7 M voxels) runs in spans:
// the partials pass once per span, continuing the same Welford triples, then
// the statistics once, then the apply pass once per span.
// The output may be stored as fp16 (GroupNormShape::f16_output: the operand
// of the convolution that follows, read as R16_SFLOAT texels); statistics and
// arithmetic stay fp32, only the store rounds.
// CPU reference: nn::cpu::group_norm / scale_shift / silu (below, group_norm_cpu.cpp).
// Tests: tests/nn/test_group_norm.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>

namespace icube::kernels::nn {

struct GroupNormShape {
  uint32_t batch = 1, channels = 32, groups = 32;
  uint64_t spatial = 1;  // X * Y * Z
  float eps = 1e-5f;
  bool silu = false;
  bool modulate = false;  // needs a [batch, 2 * channels] (scale, shift) modulation buffer
  bool f16_output = false;  // y stored as fp16 (round to nearest even; nn/group_norm_apply_f16out.comp)
};

class GroupNorm {
 public:
  explicit GroupNorm(gpu::Context& ctx);
  // Bytes of scratch record() needs (partials and statistics).
  static uint64_t scratch_bytes(const GroupNormShape& s);
  void record(gpu::CommandList& cmd, const GroupNormShape& s, const gpu::Buffer& x, const gpu::Buffer& weight,
              const gpu::Buffer& bias, const gpu::Buffer* modulation, const gpu::Buffer& scratch, const gpu::Buffer& y);

  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  gpu::Program& partials_;
  gpu::Program& stats_;
  gpu::Program& apply_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// Biased variance over (C/G) x spatial per group, eps inside the sqrt, affine per channel (PyTorch's GroupNorm).
CpuTensor group_norm(const CpuTensor& x, int groups, const CpuTensor& weight, const CpuTensor& bias, double eps);
// h * (1 + scale[b, c]) + shift[b, c] over the spatial axes of h [B, C, ...]; ss [B, 2C] = (scale, shift).
CpuTensor scale_shift(CpuTensor h, const CpuTensor& ss);
// h + e[b, c] over the spatial axes; e [B, C].
CpuTensor add_channel_bias(CpuTensor h, const CpuTensor& e);

}  // namespace icube::nn::cpu
