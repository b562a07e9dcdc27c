#version 460
#extension GL_GOOGLE_include_directive : require
// splat_slice_gather: one invocation per Gaussian of a window: a member of the slice
// [key_lo, key_hi] copies its SplatGaussian row (3 texels) and its SH row (sh_texels texels)
// to its place in the slice, ranks[li] (the exclusive scan of splat_slice_flags), so the
// slice holds its Gaussians in index order, ready for the one-pass pipeline.
// The destination bindings start at slice place dst_first (an aligned place at or before the
// window's first member).
// Host module: engine/splat/depth_slices.cpp; test: tests/splat/test_depth_slices.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatSliceParams p; };
layout(binding = 0) uniform usamplerBuffer gaussians;  // R32G32B32A32_UINT, the window's rows
layout(binding = 1) uniform usamplerBuffer sh_rows;    // R32G32B32A32_UINT, the window's SH rows
layout(std430, binding = 2) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 3) readonly buffer Ranks { uint ranks[]; };
layout(std430, binding = 4) writeonly buffer DstRows { uvec4 dst_rows[]; };
layout(std430, binding = 5) writeonly buffer DstSh { uvec4 dst_sh[]; };

void main() {
  const uint li = ICUBE_THREAD_LINEAR();
  if (li >= p.n) return;
  const uint key = keys[li];
  if (key == SPLAT_SLICE_CULLED || key < p.key_lo || key > p.key_hi) return;
  const uint d = ranks[li] - p.dst_first;
  for (uint t = 0u; t < 3u; ++t) dst_rows[3u * d + t] = texelFetch(gaussians, int(3u * li + t));
  for (uint t = 0u; t < p.sh_texels; ++t) dst_sh[d * p.sh_texels + t] = texelFetch(sh_rows, int(li * p.sh_texels + t));
}
