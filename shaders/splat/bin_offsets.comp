#version 460
#extension GL_GOOGLE_include_directive : require
// splat_bin_offsets: the exclusive scan, in (tile, chunk) order, of the
// chunk-major counters of the counting-sort tile binning (counts[c · tiles + t]
// = instances of chunk c in tile t, from the count walk of
// splat/bin_chunks.comp), one invocation per tile t:
//   STAGE 0: totals[t] = Σ_c counts[c · tiles + t];
//   (the host scans totals into tile_first, exclusive: the tile's first slot)
//   STAGE 1: cursors[c · tiles + t] = tile_first[t] + Σ_{c' < c} counts[c' · tiles + t]
//     (the first output slot of (tile t, chunk c), for the emit walk) and
//     ranges[t] = [tile_first[t], tile_first[t] + totals[t]), [0, 0) for a tile
//     without instances, like the reference (rasterizer_cpu.h bin_cpu).
// The counters are chunk-major so that a walking invocation's counters are
// contiguous (cache-friendly); adjacent invocations here read adjacent
// counters. Loads go through a texel buffer (a gather on lavapipe).
// Host module: engine/splat/tile_binning_gpu.cpp; test: tests/splat/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint STAGE = 0;
layout(push_constant) uniform Push { SplatBinParams p; };
layout(binding = 0) uniform usamplerBuffer counts;  // R32_UINT, chunk-major
layout(std430, binding = 1) buffer Totals { uint totals[]; };
layout(std430, binding = 2) readonly buffer TileFirst { uint tile_first[]; };
layout(std430, binding = 3) writeonly buffer Cursors { uint cursors[]; };
layout(std430, binding = 4) writeonly buffer Ranges { uvec2 ranges[]; };

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  if (t >= p.tiles) return;
  if (STAGE == 0u) {
    uint sum = 0u;
    for (uint c = 0u; c < p.chunks; ++c) sum += texelFetch(counts, int(c * p.tiles + t)).x;
    totals[t] = sum;
  } else {
    const uint first = tile_first[t];
    uint o = first;
    for (uint c = 0u; c < p.chunks; ++c) {
      cursors[c * p.tiles + t] = o;
      o += texelFetch(counts, int(c * p.tiles + t)).x;
    }
    ranges[t] = o > first ? uvec2(first, o) : uvec2(0u);
  }
}
