// LayerNorm over channels on the GPU (shaders/nn/layer_norm.comp):
// the transformer blocks' norm1/2/3 on tokens kept channels-first
// ([batch, channels, tokens], the UNet's NCDHW with tokens = X*Y*Z), so the
// transformer's linears run as 1x1 convolutions (conv3d.h) without transposes.
// One dispatch, no barrier inside; x and y must fit one storage binding. The
// output may be stored as fp16 (LayerNormShape::f16_output: the operand of the
// linear that follows; the statistics stay fp32, only the store rounds).
// CPU reference: nn::cpu::layer_norm on the transposed tensor (below, layer_norm_cpu.cpp).
// Tests: tests/nn/test_layer_norm.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>

namespace icube::kernels::nn {

struct LayerNormShape {
  uint32_t batch = 1, channels = 1;
  uint64_t tokens = 1;
  float eps = 1e-5f;
  bool f16_output = false;  // y stored as fp16 (round to nearest even; nn/layer_norm_f16out.comp)
};

class LayerNorm {
 public:
  explicit LayerNorm(gpu::Context& ctx);
  void record(gpu::CommandList& cmd, const LayerNormShape& s, const gpu::Buffer& x, const gpu::Buffer& weight,
              const gpu::Buffer& bias, const gpu::Buffer& y);

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// Over the last axis, biased variance (PyTorch's LayerNorm).
CpuTensor layer_norm(const CpuTensor& x, const CpuTensor& weight, const CpuTensor& bias, double eps = 1e-5);

}  // namespace icube::nn::cpu
