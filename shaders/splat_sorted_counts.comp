#version 460
#extension GL_GOOGLE_include_directive : require
// splat_sorted_counts: one invocation per depth-sorted position j;
// counts[j] = touched[order[j]], the tiles touched by the j-th nearest
// Gaussian (order[] = Gaussian indices stably sorted by view depth). Its
// inclusive scan places each Gaussian's tile instances in depth order, so a
// stable sort of the instances by tile id alone gives the (tile, depth) order.
// Host module: engine/splat/rasterizer_gpu.cpp; test: tests/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatDuplicateParams p; };
layout(std430, binding = 0) readonly buffer Order { uint order[]; };
layout(std430, binding = 1) readonly buffer Touched { uint touched[]; };
layout(std430, binding = 2) writeonly buffer Counts { uint counts[]; };

void main() {
  const uint j = ICUBE_THREAD_LINEAR();
  if (j >= p.n) return;
  counts[j] = touched[order[j]];
}
