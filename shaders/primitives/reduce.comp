#version 460
#extension GL_GOOGLE_include_directive : require
// reduce: sum / min / max of a uint32, int32 or float32 array, per tile.
//
// partials[out_base + t] = OP over in[t*TILE .. min((t+1)*TILE, n)), stored
// as raw 32-bit words (floats by bit pattern). The host reduces the partials
// again until one value is left. OP (spec 2): 0 sum, 1 min, 2 max. TYPE
// (spec 3): 0 uint32 (sums wrap), 1 int32, 2 float32 (sums in fp32; NaN
// inputs propagate through sum, min/max follow GLSL min/max).
// One workgroup is one subgroup; register accumulation, one subgroup
// reduction at the end, no shared memory.
// Host module and CPU reference: kernels/reduce.{h,cpp}.
// Tests: tests/primitives/test_reduce.cpp, tests/gpu/test_large_buffers.cpp.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "shared/primitives_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint TILE = 4096;
layout(constant_id = 2) const uint OP = 0;
layout(constant_id = 3) const uint TYPE = 0;

layout(push_constant) uniform Push { ReduceParams p; };
layout(std430, binding = 0) readonly buffer In { uint data_in[]; };
layout(std430, binding = 1) writeonly buffer Partials { uint partials[]; };

void main() {
  uint tile = icube_group_linear();
  uint begin = tile * TILE;
  if (begin >= p.n) return;
  uint end = min(begin + TILE, p.n);
  uint lane_first = begin + gl_SubgroupInvocationID;
  // Lanes past `end` start from the first element of the tile: a neutral
  // value for min/max, and 0 for sums.
  uint seed = data_in[lane_first < end ? lane_first : begin];
  uint result;
  if (TYPE == 2u) {
    float acc = OP == 0u ? (lane_first < end ? uintBitsToFloat(seed) : 0.0) : uintBitsToFloat(seed);
    for (uint i = lane_first + gl_SubgroupSize; i < end; i += gl_SubgroupSize) {
      float v = uintBitsToFloat(data_in[i]);
      acc = OP == 0u ? acc + v : (OP == 1u ? min(acc, v) : max(acc, v));
    }
    acc = OP == 0u ? subgroupAdd(acc) : (OP == 1u ? subgroupMin(acc) : subgroupMax(acc));
    result = floatBitsToUint(acc);
  } else if (TYPE == 1u) {
    int acc = OP == 0u ? (lane_first < end ? int(seed) : 0) : int(seed);
    for (uint i = lane_first + gl_SubgroupSize; i < end; i += gl_SubgroupSize) {
      int v = int(data_in[i]);
      acc = OP == 0u ? acc + v : (OP == 1u ? min(acc, v) : max(acc, v));
    }
    acc = OP == 0u ? subgroupAdd(acc) : (OP == 1u ? subgroupMin(acc) : subgroupMax(acc));
    result = uint(acc);
  } else {
    uint acc = OP == 0u ? (lane_first < end ? seed : 0u) : seed;
    for (uint i = lane_first + gl_SubgroupSize; i < end; i += gl_SubgroupSize) {
      uint v = data_in[i];
      acc = OP == 0u ? acc + v : (OP == 1u ? min(acc, v) : max(acc, v));
    }
    acc = OP == 0u ? subgroupAdd(acc) : (OP == 1u ? subgroupMin(acc) : subgroupMax(acc));
    result = acc;
  }
  if (subgroupElect()) partials[p.out_base + tile] = result;
}
