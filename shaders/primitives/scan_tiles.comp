#version 460
#extension GL_GOOGLE_include_directive : require
// scan_tiles: prefix sum of uint32 within tiles, with an optional carry-in.
//
// out[i] = carry + sum(in[tile_start .. i]) (inclusive) or that minus in[i]
// (exclusive), where carry = tile_prefix[tile_base + tile] when has_prefix,
// else 0. Sums wrap modulo 2^32. In-place (in == out) is allowed: every
// element is read and written by the same invocation.
// One workgroup is one subgroup; lanes take contiguous subgroup-wide batches
// and the running carry stays subgroup-uniform in a register.
// Host module and CPU reference: kernels/prefix_scan.{h,cpp}.
// Tests: tests/primitives/test_prefix_scan.cpp, tests/gpu/test_large_buffers.cpp.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "shared/primitives_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint TILE = 4096;

layout(push_constant) uniform Push { ScanParams p; };
layout(std430, binding = 0) readonly buffer In { uint data_in[]; };
layout(std430, binding = 1) writeonly buffer Out { uint data_out[]; };
layout(std430, binding = 2) readonly buffer Prefix { uint tile_prefix[]; };

void main() {
  uint tile = icube_group_linear();
  uint begin = tile * TILE;
  if (begin >= p.n) return;
  uint end = min(begin + TILE, p.n);
  uint carry = p.has_prefix != 0u ? tile_prefix[p.tile_base + tile] : 0u;
  for (uint base = begin; base < end; base += gl_SubgroupSize) {
    uint i = base + gl_SubgroupInvocationID;
    uint v = i < end ? data_in[i] : 0u;
    uint incl = subgroupInclusiveAdd(v);
    if (i < end) data_out[i] = carry + (p.inclusive != 0u ? incl : incl - v);
    carry += subgroupBroadcast(incl, gl_SubgroupSize - 1u);
  }
}
