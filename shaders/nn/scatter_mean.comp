#version 460
#extension GL_GOOGLE_include_directive : require
// scatter_mean: the voxel lifter's mean, y[v, c] = (sum over voxel v's list of
// effective pixels q = n * plane + p, in list order = ascending q, of
// features[n, c, p]) / (list length), 0 for an empty list. One invocation per
// (voxel, channel) of the window, consecutive invocations the channels of one
// voxel (they share the list: uniform offset and pixel-id loads). The sum is a
// plain float32 loop in list order, so it is deterministic; a dispatch may
// cover only the list entries in views [view_begin, view_end) (found by binary
// search) and only its pass's pixel_window of them: the first dispatch of a
// list (its position offsets[v]) starts from 0, later ones continue the
// partial sum kept in y, and the one that reaches the list's end divides —
// the same operations in the same order as one loop. Features, offsets and
// pixel ids are texel buffers (gathers on lavapipe).
// Host module: kernels/nn/scatter_mean.{h,cpp}; CPU reference:
// nn::cpu::scatter_mean. Tests: tests/nn/test_scatter_mean.cpp.
#include "shared/nn_gsm_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SM_GROUP) in;
layout(push_constant) uniform Push { ScatterMeanParams p; };
layout(binding = 0) uniform samplerBuffer features;   // R32_SFLOAT
layout(binding = 1) uniform usamplerBuffer offsets;   // R32_UINT
layout(binding = 2) uniform usamplerBuffer pixel_ids; // R32_UINT
layout(std430, binding = 3) buffer Out { float y_out[]; };

uint pixel_at(uint pos) { return texelFetch(pixel_ids, int(p.pixels_offset + (pos - p.pixel_first))).x; }

// The first list position in [lo, hi) whose pixel id is >= key (hi if none).
uint lower_bound(uint lo, uint hi, uint key) {
  while (lo < hi) {
    const uint mid = lo + (hi - lo) / 2u;
    if (pixel_at(mid) < key) lo = mid + 1u;
    else hi = mid;
  }
  return lo;
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.voxels * p.channels) return;
  const uint v = i / p.channels, cl = i % p.channels;
  const uint lo = texelFetch(offsets, int(p.offsets_offset + v)).x;
  const uint hi = texelFetch(offsets, int(p.offsets_offset + v + 1u)).x;
  const uint yi = p.y_offset + v * p.channels_total + p.channel_begin + cl;
  if (lo == hi) {
    if ((p.flags & NN_SM_FLAG_FIRST) != 0u) y_out[yi] = 0.0;
    return;
  }
  uint a = lo, b = hi;
  if ((p.flags & NN_SM_FLAG_ALL_VIEWS) == 0u) {
    a = lower_bound(lo, hi, p.view_begin * p.plane);
    b = lower_bound(a, hi, p.view_end * p.plane);
  }
  const uint s = a + p.pass * p.pixel_window;
  if (s >= b) return;
  const uint e = min(b, s + p.pixel_window);
  float acc = s == lo ? 0.0 : y_out[yi];
  const uint channel_base = p.x_offset + cl * p.plane;
  const uint view_stride = p.channels_total * p.plane;
  for (uint pos = s; pos < e; ++pos) {
    const uint q = pixel_at(pos);
    const uint n = q / p.plane;
    acc += texelFetch(features, int(channel_base + (n - p.view_begin) * view_stride + (q - n * p.plane))).x;
  }
  y_out[yi] = e == hi ? acc / float(hi - lo) : acc;
}
