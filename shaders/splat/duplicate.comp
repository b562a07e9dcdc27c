#version 460
#extension GL_GOOGLE_include_directive : require
// splat_duplicate: one invocation per depth-sorted position j (order[] =
// Gaussian indices stably sorted by view depth); writes one (key, value) per
// tile of Gaussian order[j]'s rect (with p.cull only those its α-cut ellipse
// reaches: exact tile culling, splat/tiles.glsl, from the depth-ordered
// bin record's mean, conic and log_cut), row-major over the rect, at offsets from
// the inclusive scan of the depth-ordered tile counts (splat_sorted_counts).
// key = tile id (uint32), value = Gaussian index. The instances are thus in
// (depth, Gaussian index) order, and the host's stable radix sort by the
// tile-id bits only yields the reference order (tile, depth, index) of the
// 64-bit keys tile << 32 | depth bits. No atomics: deterministic.
// Host module: engine/splat/rasterizer_gpu.cpp; test: tests/splat/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatDuplicateParams p; };
// Per-Gaussian loads at i = order[j] are divergent: they go through texel buffers
// (a gather on lavapipe; a per-lane loop as storage-buffer loads); records are
// fetched as R32G32B32A32_UINT and bit-cast (exact).
layout(std430, binding = 0) readonly buffer Order { uint order[]; };
// R32G32B32A32_UINT: 2 texels per SplatBinRecord, in depth order (splat_sorted_counts).
layout(binding = 1) uniform usamplerBuffer bin_records;
layout(std430, binding = 2) readonly buffer Counts { uint counts[]; };
layout(std430, binding = 3) readonly buffer Offsets { uint offsets_incl[]; };
layout(std430, binding = 4) writeonly buffer Keys { uint keys[]; };
layout(std430, binding = 5) writeonly buffer Values { uint values[]; };

#include "splat/tiles.glsl"

void main() {
  const uint j = ICUBE_THREAD_LINEAR();
  if (j >= p.n) return;
  const uint count = counts[j];
  if (count == 0u) return;
  const uint i = order[j];
  uint o = offsets_incl[j] - count;
  vec4 g0, g1;
  uvec4 r;
  splat_read_bin_record(bin_records, j, g0, g1, r);
  for (uint y = r.y; y < r.w; ++y) {
    const uvec2 span = p.cull != 0u ? splat_tile_row(g0.x, g0.y, g0.z, g0.w, g1.x, g1.y, r, y) : r.xz;
    for (uint x = span.x; x < span.y; ++x) {
      keys[o] = (y - p.tile_y0) * p.grid_x + x;
      values[o] = i;
      ++o;
    }
  }
}
