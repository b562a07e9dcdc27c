// Fill helpers: iota on the GPU (payload indices for key-value sorts).
// Constant fills and copies use CommandList::fill_buffer / copy_buffer.
//
// Shader: shaders/primitives/iota.comp. Tests: tests/primitives/test_fill.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstdint>
#include <vector>

namespace icube::kernels {

class Iota {
 public:
  explicit Iota(gpu::Context& ctx);
  // Records out[i] = start + i * step (uint32, wrapping) for i < n (one binding; n*4 <= maxStorageBufferRange).
  void record(gpu::CommandList& cmd, const gpu::Buffer& out, uint64_t n, uint32_t start = 0, uint32_t step = 1);

 private:
  gpu::Program& program_;
};

std::vector<uint32_t> iota_cpu(uint64_t n, uint32_t start = 0, uint32_t step = 1);

}  // namespace icube::kernels
