#version 460
#extension GL_GOOGLE_include_directive : require
// splat_slice_flags: one invocation per Gaussian of a window: flags[li] = 1 when its slice key
// lies in the slice [key_lo, key_hi] (culled ones never do), else 0. Their exclusive scan over
// the whole frame gives each member its place in the slice, in Gaussian index order.
// Host module: engine/splat/depth_slices.cpp; test: tests/splat/test_depth_slices.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatSliceParams p; };
layout(std430, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 1) writeonly buffer Flags { uint flags[]; };

void main() {
  const uint li = ICUBE_THREAD_LINEAR();
  if (li >= p.n) return;
  const uint key = keys[li];
  flags[li] = key != SPLAT_SLICE_CULLED && key >= p.key_lo && key <= p.key_hi ? 1u : 0u;
}
