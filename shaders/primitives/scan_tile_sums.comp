#version 460
#extension GL_GOOGLE_include_directive : require
// scan_tile_sums: first pass of the reduce-then-scan prefix sum.
//
// Computes tile_sums[tile_base + t] = sum of in[t*TILE .. min((t+1)*TILE, n))
// (uint32, wrapping) for every tile t of one window. One workgroup is exactly
// one subgroup (local_size_x = subgroup size, pinned by the host); its lanes
// walk the tile in subgroup-wide batches with contiguous loads, accumulate in
// registers and reduce once at the end: no shared memory, no barriers.
// Host module and CPU reference: kernels/prefix_scan.{h,cpp}.
// Tests: tests/primitives/test_prefix_scan.cpp, tests/gpu/test_large_buffers.cpp.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "shared/primitives_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint TILE = 4096;

layout(push_constant) uniform Push { ScanParams p; };
layout(std430, binding = 0) readonly buffer In { uint data_in[]; };
layout(std430, binding = 1) writeonly buffer Sums { uint tile_sums[]; };

void main() {
  uint tile = icube_group_linear();
  uint begin = tile * TILE;
  if (begin >= p.n) return;
  uint end = min(begin + TILE, p.n);
  uint acc = 0;
  for (uint i = begin + gl_SubgroupInvocationID; i < end; i += gl_SubgroupSize) acc += data_in[i];
  uint total = subgroupAdd(acc);
  if (subgroupElect()) tile_sums[p.tile_base + tile] = total;
}
