// The network's small element-wise kernels: SiLU, GELU (exact), ReLU, add, GEGLU's gating
// (shaders/nn/elementwise.comp). No barrier inside. When a tensor exceeds one
// storage binding they run in windows: the activations and add over flat ranges, GEGLU per
// batch element over flat ranges of its value and gate halves.
// CPU references (below, elementwise_cpu.cpp): nn::cpu::silu / gelu / relu / add.
// Tests: tests/nn/test_elementwise.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>

namespace icube::kernels::nn {

class Elementwise {
 public:
  explicit Elementwise(gpu::Context& ctx);
  void silu(gpu::CommandList& cmd, const gpu::Buffer& x, uint64_t count, const gpu::Buffer& y);
  void gelu(gpu::CommandList& cmd, const gpu::Buffer& x, uint64_t count, const gpu::Buffer& y);
  void relu(gpu::CommandList& cmd, const gpu::Buffer& x, uint64_t count, const gpu::Buffer& y);
  void add(gpu::CommandList& cmd, const gpu::Buffer& a, const gpu::Buffer& b, uint64_t count, const gpu::Buffer& y);
  // x channels-first [batch, 2 * channels, tokens] -> y [batch, channels, tokens].
  void geglu(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t batch, uint32_t channels, uint64_t tokens,
             const gpu::Buffer& y);

  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  void run(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& a, uint64_t a_count, const gpu::Buffer* b,
           uint64_t count, uint32_t channels, uint64_t tokens, const gpu::Buffer& y);
  // Flat windows of y[y_first + i] = op(a[a_first + i], b[b_first + i]), i < count.
  void run_flat(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& a, uint64_t a_first, const gpu::Buffer* b,
                uint64_t b_first, const gpu::Buffer& y, uint64_t y_first, uint64_t count);
  gpu::Context& ctx_;
  uint64_t max_binding_bytes_ = 0;
  gpu::Program& elementwise_;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

CpuTensor silu(CpuTensor x);
CpuTensor gelu(CpuTensor x);                     // exact (erf), as F.gelu's default
CpuTensor relu(CpuTensor x);
CpuTensor add(CpuTensor a, const CpuTensor& b);  // same shapes

}  // namespace icube::nn::cpu
