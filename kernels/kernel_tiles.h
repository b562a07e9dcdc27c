// Conventions shared by the "one subgroup per tile" primitive kernels
// (scan, reduce, radix sort): the workgroup is exactly one subgroup and walks
// a tile of kTileElements in subgroup-wide batches.
#pragma once

#include "gpu/commands.h"
#include "gpu/program.h"

#include <cstdint>

namespace icube::kernels {

// Elements per workgroup. A multiple of every subgroup size up to 128; large
// enough that per-tile bookkeeping (256 radix counters, one partial sum) is
// cheap, small enough that 20M elements still make thousands of workgroups.
inline constexpr uint32_t kTileElements = 4096;

// Spec constant ids used by these kernels.
inline constexpr uint32_t kSpecLocalSizeX = 0;
inline constexpr uint32_t kSpecTile = 1;
inline constexpr uint32_t kSpecRadixLanes = 2;  // primitives/radix_common.glsl RADIX_LANES

inline uint64_t tiles_for(uint64_t n) { return gpu::div_up(n, kTileElements); }

// Specialisation for a one-subgroup-per-workgroup kernel on `ctx`.
inline gpu::SpecConstants subgroup_tile_spec(const gpu::Context& ctx) {
  gpu::SpecConstants s;
  s.set(kSpecLocalSizeX, ctx.subgroup_size() /* local_size_x = one subgroup */);
  s.set(kSpecTile, kTileElements);
  return s;
}

// Thread count that makes `tiles` workgroups of one subgroup each.
inline uint64_t threads_for_tiles(const gpu::Context& ctx, uint64_t tiles) { return tiles * ctx.subgroup_size(); }

}  // namespace icube::kernels
