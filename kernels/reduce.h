// Sum / min / max of uint32, int32 or float32 arrays of any length.
//
// Each workgroup (one subgroup) reduces a tile to one partial; partials are
// reduced again until one value is left. Arrays larger than one storage
// binding are processed as windows. uint32/int32 sums wrap modulo 2^32;
// float32 sums accumulate in fp32 (compare with a tolerance).
//
// Shader: shaders/primitives/reduce.comp. Tests: tests/primitives/test_reduce.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstdint>
#include <vector>

namespace icube::kernels {

enum class ReduceOp : uint32_t { Sum = 0, Min = 1, Max = 2 };
enum class ElementType : uint32_t { U32 = 0, I32 = 1, F32 = 2 };

class Reduce {
 public:
  Reduce(gpu::Context& ctx, ReduceOp op, ElementType type);

  // uint32 words of scratch record() needs for `n` elements.
  static uint64_t scratch_elements(uint64_t n);

  // Records result_word[result_offset] = OP(in[0..n)) as a raw 32-bit word.
  // n must be > 0. Barriers between the levels are explicit inside; the caller
  // orders `in` before and `result` after.
  void record(gpu::CommandList& cmd, const gpu::Buffer& in, uint64_t n, const gpu::Buffer& scratch,
              const gpu::Buffer& result, uint64_t result_offset = 0);

  // Convenience: allocates scratch, submits, waits and returns the raw word.
  uint32_t run(const gpu::Buffer& in, uint64_t n);

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
};

// Plain-loop CPU references (float sums in double, then rounded).
uint32_t reduce_cpu_u32(const std::vector<uint32_t>& v, ReduceOp op);
int32_t reduce_cpu_i32(const std::vector<int32_t>& v, ReduceOp op);
float reduce_cpu_f32(const std::vector<float>& v, ReduceOp op);

}  // namespace icube::kernels
