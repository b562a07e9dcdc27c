// Push constants of the primitive kernels (scan, reduce, radix sort, iota).
// Shared by shaders/*.comp and kernels/*.cpp.
#ifndef ICUBE_PRIMITIVES_PARAMS_H
#define ICUBE_PRIMITIVES_PARAMS_H
#include "gpu_types.h"

ICUBE_SHADER_NAMESPACE_BEGIN

// scan_tile_sums / scan_tiles: one workgroup (one subgroup) per tile.
struct ScanParams {
  uint n;           // elements in this window
  uint tile_base;   // global index of this window's first tile (into tile sums / prefixes)
  uint inclusive;   // scan_tiles: 1 = inclusive, 0 = exclusive
  uint has_prefix;  // scan_tiles: 1 = add tile_prefix[tile_base + tile] as carry-in
};

// reduce: one workgroup (one subgroup) per tile, writes partials[out_base + tile].
struct ReduceParams {
  uint n;
  uint out_base;
  uint pad0;
  uint pad1;
};

// radix_count* / radix_scatter*: one workgroup (one subgroup) per tile of a source window.
// Arrays over one storage binding are bound in windows: workgroup g handles tile
// tile_first + g, whose keys sit at index - tile_first * TILE of the bound source window;
// the scatter writes only destinations in [dst_first, dst_first + dst_count), at
// dst - dst_first of the bound destination window (one dispatch per source x destination
// window; one of each when the arrays fit one binding).
struct RadixParams {
  uint n;          // elements of the whole array
  uint shift;      // bit position of the digit within the key (0..63)
  uint num_tiles;  // tiles in the whole array (histogram is digit-major: [256][num_tiles])
  uint digit_mask; // 0xff, or fewer bits on the last pass when sorting by the low key_bits only
  uint tile_first; // first tile of the bound source window
  uint dst_first;  // scatter: first element of the bound destination window
  uint dst_count;  // scatter: elements of the bound destination window
  uint pad0;
};

// iota: out[i] = start + i * step for i < n.
struct IotaParams {
  uint n;
  uint start;
  uint step;
  uint pad0;
};

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(ScanParams, 16);
ICUBE_CHECK_LAYOUT(ScanParams, tile_base, 4);
ICUBE_CHECK_LAYOUT(ScanParams, has_prefix, 12);
ICUBE_CHECK_SIZE(ReduceParams, 16);
ICUBE_CHECK_LAYOUT(ReduceParams, out_base, 4);
ICUBE_CHECK_SIZE(RadixParams, 32);
ICUBE_CHECK_LAYOUT(RadixParams, tile_first, 16);
ICUBE_CHECK_LAYOUT(RadixParams, dst_count, 24);
ICUBE_CHECK_LAYOUT(RadixParams, shift, 4);
ICUBE_CHECK_LAYOUT(RadixParams, num_tiles, 8);
ICUBE_CHECK_LAYOUT(RadixParams, digit_mask, 12);
ICUBE_CHECK_SIZE(IotaParams, 16);
ICUBE_CHECK_LAYOUT(IotaParams, step, 8);

#endif
