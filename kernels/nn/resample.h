// The UNet's resampling on the GPU (shaders/nn/resample.comp): 2x2x2 average
// pooling and nearest x2 upsampling of [planes, X, Y, Z] volumes. No barrier
// inside. A tensor over one storage binding runs in windows of whole planes or,
// for a plane over one binding, slabs of whole x slices.
// CPU references (below, resample_cpu.cpp): nn::cpu::avg_pool2 / upsample2.
// Tests: tests/nn/test_resample.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>

namespace icube::kernels::nn {

class Resample {
 public:
  explicit Resample(gpu::Context& ctx);
  // x [planes, X, Y, Z] -> y [planes, X/2, Y/2, Z/2] or [planes, 2X, 2Y, 2Z].
  void avg_pool2(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy, uint32_t sz,
                 const gpu::Buffer& y);
  void upsample2(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy, uint32_t sz,
                 const gpu::Buffer& y);

  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  void run(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy,
           uint32_t sz, const gpu::Buffer& y);
  gpu::Context& ctx_;
  uint64_t max_binding_bytes_ = 0;
  gpu::Program& resample_;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// 2x2x2 mean, stride 2, sizes floored; nearest x2. x [B, C, X, Y, Z].
CpuTensor avg_pool2(const CpuTensor& x);
CpuTensor upsample2(const CpuTensor& x);

}  // namespace icube::nn::cpu
