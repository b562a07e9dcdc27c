// The per-tile range stage shared by the splatting rasterizer's radix binning and the
// Gaussian LiDAR's binning: zero-fill the ranges, then shaders/splat/ranges.comp over the
// sorted keys (key_words = 1: 32-bit tile ids; 2: 64-bit keys with the tile id in the high
// word) writes ranges[t] = [first, end) of tile t's instances.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "gpu/program.h"

#include <cstdint>

namespace icube::splat {

// Records, in order: the fill of `ranges` (tiles uvec2), a transfer-to-compute barrier (the
// kernel writes into the zeroed ranges), a compute-to-compute barrier (it reads the keys the
// caller's sort just wrote) and the range kernel (`ranges_program` = splat_ranges) when
// `instances` > 0. The caller orders what reads the ranges with its own barrier.
void record_tile_ranges(gpu::CommandList& cmd, gpu::Program& ranges_program, const gpu::Buffer& keys,
                        uint32_t key_words, uint64_t instances, const gpu::Buffer& ranges, uint32_t tiles);

}  // namespace icube::splat
