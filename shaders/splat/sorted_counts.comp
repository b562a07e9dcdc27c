#version 460
#extension GL_GOOGLE_include_directive : require
// splat_sorted_counts: one invocation per depth-sorted position j (order[] =
// Gaussian indices stably sorted by view depth); counts[j] = the tile
// instances of Gaussian i = order[j]: with p.cull (exact tile culling) the
// tiles of its rect that its α-cut ellipse reaches (splat/tiles.glsl,
// from the blend record's mean, conic and log_cut; rasterizer_cpu.h
// tile_count), else the rect's area (= preprocess's touched[i]; 0 when culled). Its inclusive
// scan places each Gaussian's tile instances in depth order, so a stable sort
// of the instances by tile id alone gives the (tile, depth) order. It also
// writes bin_records[j] (SplatBinRecord: mean, conic, log_cut and the tile
// rect of Gaussian order[j]) for the binning kernels, which then read in depth
// order instead of gathering by Gaussian index.
// Host module: engine/splat/rasterizer_gpu.cpp; test: tests/splat/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatDuplicateParams p; };
// Per-Gaussian loads at i = order[j] are divergent: they go through texel buffers
// (a gather on lavapipe; a per-lane loop as storage-buffer loads); records are
// fetched as R32G32B32A32_UINT and bit-cast (exact).
layout(std430, binding = 0) readonly buffer Order { uint order[]; };
layout(std430, binding = 1) writeonly buffer Counts { uint counts[]; };
layout(binding = 2) uniform usamplerBuffer rects;    // R32G32B32A32_UINT (zero when culled)
layout(binding = 3) uniform usamplerBuffer records;  // R32G32B32A32_UINT: 3 texels per SplatBlendRecord
layout(std430, binding = 4) writeonly buffer BinRecords { SplatBinRecord bin_records[]; };

#include "splat/tiles.glsl"

void main() {
  const uint j = ICUBE_THREAD_LINEAR();
  if (j >= p.n) return;
  const uint i = order[j];
  const uvec4 r = texelFetch(rects, int(i));  // zero when culled
  const uint t = (r.z - r.x) * (r.w - r.y);    // = touched[i], the whole rect (0 when culled)
  const vec4 g0 = uintBitsToFloat(texelFetch(records, int(3u * i)));
  const vec4 g1 = uintBitsToFloat(texelFetch(records, int(3u * i + 1u)));
  bin_records[j] = splat_pack_bin_record(g0, g1, r);
  if (p.cull == 0u || t == 0u) {
    counts[j] = t;
    return;
  }
  uint count = 0u;
  for (uint y = r.y; y < r.w; ++y) {
    const uvec2 span = splat_tile_row(g0.x, g0.y, g0.z, g0.w, g1.x, g1.y, r, y);
    count += span.y - span.x;
  }
  counts[j] = count;
}
