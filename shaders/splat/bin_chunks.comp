#version 460
#extension GL_GOOGLE_include_directive : require
// splat_bin_chunks: the two walks of the stable counting sort of the tile
// instances by tile (the binning path for CPU devices such as lavapipe;
// engine/splat/tile_binning_gpu.h). Instance k of the depth-ordered list is
// tile number k − excl[j] (row-major over the rect, with p.cull only the rect
// tiles its α-cut ellipse reaches: exact tile culling, splat/tiles.glsl,
// from the depth-ordered bin record's mean, conic and log_cut; else the whole rect) of
// Gaussian i = order[j] (order = Gaussian indices stably sorted by view depth),
// where offsets[j] = incl[j] is the inclusive scan of the depth-ordered tile
// counts (splat/sorted_counts.comp) and excl[j] = incl[j] − count. The list
// [0, p.instances) is split into p.chunks chunks of p.chunk_len instances;
// invocation c walks chunk c sequentially (one loop iteration per instance,
// plus one per empty rect row or Gaussian without instances) and uses its
// private counter counters[c · p.tiles + tile] (chunk-major: a walk's counters
// are contiguous; one writer per counter, no atomics, deterministic):
//   EMIT = 0 (count walk): counters += 1 (the host zeroes them first);
//   EMIT = 1 (emit walk): counters = the first output slot of (tile, chunk)
//     (splat/bin_offsets.comp: the exclusive scan in (tile, chunk) order):
//     values[counters++] = i.
// Chunks are contiguous in the depth order, so the emitted list is the
// reference's (tile, depth, Gaussian index) order (rasterizer_cpu.h bin_cpu).
// lavapipe ends every loop of an invocation once the invocation's loops have
// made 65,535 iterations in all (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS): a walk
// that did not reach its chunk's end sets incomplete = 1, and the host then
// bins the frame with the radix path instead (the host keeps chunks far below
// that: TileBinningGpu::kMaxInstancesPerChunk).
// Host module: engine/splat/tile_binning_gpu.cpp; test: tests/splat/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint EMIT = 0;
layout(push_constant) uniform Push { SplatBinParams p; };
// The lanes walk chunks p.chunk_len instances apart, so every per-Gaussian load
// is divergent: texel fetches (a gather on lavapipe, a per-lane loop as
// storage-buffer loads); records are fetched as R32G32B32A32_UINT and bit-cast
// (exact).
layout(binding = 0) uniform usamplerBuffer order;    // R32_UINT
layout(binding = 1) uniform usamplerBuffer offsets;  // R32_UINT: inclusive scan of the depth-ordered counts
// R32G32B32A32_UINT: 2 texels per SplatBinRecord, in depth order (splat_sorted_counts), so a
// walk streams through them.
layout(binding = 2) uniform usamplerBuffer bin_records;
layout(std430, binding = 3) buffer Counters { uint counters[]; };
layout(std430, binding = 4) writeonly buffer Values { uint values[]; };
layout(std430, binding = 5) buffer Incomplete { uint incomplete; };

#include "splat/tiles.glsl"

uint incl(uint j) { return texelFetch(offsets, int(j)).x; }

// The Gaussian at depth position j: index, rect, mean/conic/cut.
void load_gaussian(uint j, out uint i, out uvec4 r, out vec4 g0, out vec4 g1) {
  i = texelFetch(order, int(j)).x;
  splat_read_bin_record(bin_records, j, g0, g1, r);
}

// [x0, x1) of rect row y (empty for an empty or culled rect: its record is unused).
uvec2 row_span(uvec4 r, vec4 g0, vec4 g1, uint y) {
  if (y >= r.w) return uvec2(0u);
  return p.cull != 0u ? splat_tile_row(g0.x, g0.y, g0.z, g0.w, g1.x, g1.y, r, y) : r.xz;
}

void main() {
  const uint c = ICUBE_THREAD_LINEAR();
  if (c >= p.chunks) return;
  const uint a = c * p.chunk_len;
  if (a >= p.instances) return;
  const uint b = min(p.instances, a + p.chunk_len);
  // The Gaussian holding instance a: the first j with incl[j] > a (incl[n - 1] = instances).
  uint lo = 0u, hi = p.n - 1u;
  while (lo < hi) {
    const uint mid = (lo + hi) >> 1u;
    if (incl(mid) > a) hi = mid;
    else lo = mid + 1u;
  }
  uint j = lo, i;
  uvec4 r;
  vec4 g0, g1;
  load_gaussian(j, i, r, g0, g1);
  const uint first = j == 0u ? 0u : incl(j - 1u);
  // Its tile number a - first: skip whole rows.
  uint skip = a - first, y = r.y;
  uvec2 span = row_span(r, g0, g1, y);
  while (skip >= span.y - span.x && y < r.w) {
    skip -= span.y - span.x;
    ++y;
    span = row_span(r, g0, g1, y);
  }
  uint x = span.x + skip, xend = span.y;
  uint k = a;
  // One iteration: step to the next row (else the next Gaussian) when the row is done, then
  // emit one instance if the row has one left. Both halves run in most iterations (masked on
  // lavapipe), so a step and an emit share an iteration.
  while (k < b) {
    if (x >= xend) {
      if (y + 1u < r.w) {
        ++y;
      } else {
        if (j + 1u >= p.n) break;  // never with counts that match the walk; flagged below
        ++j;
        load_gaussian(j, i, r, g0, g1);
        y = r.y;
      }
      span = row_span(r, g0, g1, y);
      x = span.x;
      xend = span.y;
    }
    if (x < xend) {
      const uint t = c * p.tiles + (y - p.tile_y0) * p.grid_x + x;
      if (EMIT != 0u) {
        const uint slot = counters[t];
        counters[t] = slot + 1u;
        values[slot] = i;
      } else {
        counters[t] += 1u;
      }
      ++x;
      ++k;
    }
  }
  if (k != b) atomicOr(incomplete, 1u);
}
