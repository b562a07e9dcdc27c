#version 460
#extension GL_GOOGLE_include_directive : require
// splat_slice_histogram: one invocation per Gaussian of a window: a Gaussian whose slice key
// lies in [key_lo, key_hi] (culled ones never do) adds 1 to its bucket's count and its tile
// rect's area to the bucket's 64-bit tile total; bucket = (key - key_lo) >> shift. The
// binding holds the window of buckets [bucket_first, bucket_first + bucket_count): for bucket
// b = bucket_first + k, hist[3k] = count, hist[3k + 1] / hist[3k + 2] = low / high word of the
// tile total. The host zeroes hist first and cuts the frame into depth slices from it
// (depth_slices.h).
// Host module: engine/splat/depth_slices.cpp; test: tests/splat/test_depth_slices.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatSliceParams p; };
layout(std430, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 1) readonly buffer Tiles { uint tiles[]; };
layout(std430, binding = 2) buffer Hist { uint hist[]; };

void main() {
  const uint li = ICUBE_THREAD_LINEAR();
  if (li >= p.n) return;
  const uint key = keys[li];
  if (key == SPLAT_SLICE_CULLED || key < p.key_lo || key > p.key_hi) return;
  const uint bucket = (key - p.key_lo) >> p.shift;
  if (bucket < p.bucket_first || bucket - p.bucket_first >= p.bucket_count) return;
  const uint b = bucket - p.bucket_first;
  atomicAdd(hist[3u * b], 1u);
  const uint t = tiles[li];
  if (t == 0u) return;
  const uint old = atomicAdd(hist[3u * b + 1u], t);
  if (old + t < old) atomicAdd(hist[3u * b + 2u], 1u);  // carry into the high word
}
