// The network's small element-wise kernels: SiLU, add, GEGLU's gating
// (shaders/nn/elementwise.comp) and the UNet's resampling, 2x2x2 average
// pooling and nearest x2 upsampling (shaders/nn/resample.comp). No barrier
// inside. When a tensor exceeds one storage binding they run in windows: SiLU and add
// over flat ranges, GEGLU per batch element over flat ranges of its value and gate
// halves, the resampling over whole planes or, for a plane over one binding, slabs
// of whole x slices.
// CPU references: nn::cpu::silu / add / gelu / avg_pool2 / upsample2.
// Tests: tests/nn/test_elementwise_gpu.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstdint>

namespace icube::kernels::nn {

class Elementwise {
 public:
  explicit Elementwise(gpu::Context& ctx);
  void silu(gpu::CommandList& cmd, const gpu::Buffer& x, uint64_t count, const gpu::Buffer& y);
  void add(gpu::CommandList& cmd, const gpu::Buffer& a, const gpu::Buffer& b, uint64_t count, const gpu::Buffer& y);
  // x channels-first [batch, 2 * channels, tokens] -> y [batch, channels, tokens].
  void geglu(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t batch, uint32_t channels, uint64_t tokens,
             const gpu::Buffer& y);
  // x [planes, X, Y, Z] -> y [planes, X/2, Y/2, Z/2] or [planes, 2X, 2Y, 2Z].
  void avg_pool2(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy, uint32_t sz,
                 const gpu::Buffer& y);
  void upsample2(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy, uint32_t sz,
                 const gpu::Buffer& y);

  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  void run(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& a, uint64_t a_count, const gpu::Buffer* b,
           uint64_t count, uint32_t channels, uint64_t tokens, const gpu::Buffer& y);
  // Flat windows of y[y_first + i] = op(a[a_first + i], b[b_first + i]), i < count.
  void run_flat(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& a, uint64_t a_first, const gpu::Buffer* b,
                uint64_t b_first, const gpu::Buffer& y, uint64_t y_first, uint64_t count);
  void resample(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy,
                uint32_t sz, const gpu::Buffer& y);
  gpu::Context& ctx_;
  uint64_t max_binding_bytes_ = 0;
  gpu::Program& elementwise_;
  gpu::Program& resample_;
};

}  // namespace icube::kernels::nn
