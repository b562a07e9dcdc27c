// Counting-sort tile binning of the Gaussian splatting rasterizer
// (shaders/splat/bin_chunks.comp, splat/bin_offsets.comp; the foundation
// PrefixScan), the path SplatRendererGpu takes on CPU devices (lavapipe). It
// builds the same stable (tile, depth, Gaussian index) instance list and
// per-tile ranges as the radix path (splat_duplicate + RadixSort by tile +
// splat_ranges, rasterizer_gpu.h) and the CPU reference (bin_cpu), bit for bit.
//
// Input: the frame's depth order and the inclusive scan of the depth-ordered
// tile counts (submission 1 of the rasterizer, shared by both paths), which
// place instance k at tile number k − excl[j] of Gaussian order[j]. The
// instance list is split into C chunks of equal length, one per invocation,
// each walked sequentially, one loop iteration per instance (no atomics,
// deterministic, balanced):
//   zero C counters per tile -> count walk (counter chunk·tiles + tile += 1)
//   -> per-tile totals -> exclusive PrefixScan of the totals -> each
//   (tile, chunk)'s first slot into its cursor, and the tile ranges
//   (splat_bin_offsets) -> emit walk (values[cursor++] = Gaussian index).
// The counters are chunk-major: a walking invocation's counters are contiguous
// (its working set is one row of tiles·4 bytes, not the whole array).
// Work is O(instances + tiles·C): tiles without instances cost only their C
// counters. C (chunks_for) is a multiple of the subgroup size: at least
// kChunkGroupsPerThread subgroups per device thread (LP_NUM_THREADS, else the
// host's hardware threads; at least kMinChunkGroups) so the threads share
// them, and no more, since every chunk adds a counter per tile to zero, scan
// and walk (measured chunk counts: bench/README.md), and enough that
// no chunk exceeds kMaxInstancesPerChunk (lavapipe ends an invocation's loops
// after 65,535 iterations in all); the counters stay within one storage
// binding and one texel-buffer view. A walk that still got cut short reports it (incomplete != 0) and
// the caller re-bins the frame with the radix path. Sequential walks suit a
// CPU device with few threads; a GPU would idle most of its lanes, so GPUs
// keep the radix path.
// Tests: tests/splat/test_splat.cpp; benchmark: bench/bench_splat.cpp (cull-tile vs cull-tile-radix).
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/prefix_scan.h"

#include <cstdint>

namespace icube::splat {

class TileBinningGpu {
 public:
  static constexpr uint64_t kMaxInstancesPerChunk = 32768;
  static constexpr uint32_t kMinChunkGroups = 2;
  static constexpr uint32_t kChunkGroupsPerThread = 2;
  static constexpr uint64_t kMaxChunks = 16384;  // splat_bin_offsets loops over the chunks of a tile

  explicit TileBinningGpu(gpu::Context& ctx);

  // The threads a CPU device runs shaders on: lavapipe's LP_NUM_THREADS, else (its default)
  // the host's hardware threads.
  static uint64_t device_threads();
  // Subgroups of chunks at least (the device's threads share them).
  static uint64_t chunk_groups(uint64_t threads);

  // Chunks for `instances` over `tiles` tiles; `requested` > 0 forces that many (tests,
  // benchmarks). 0 when the counters would not fit one storage binding (use the radix path).
  uint32_t chunks_for(uint64_t instances, uint32_t tiles, uint32_t requested = 0) const;

  struct Frame {
    const gpu::Buffer& order;    // n depth-sorted Gaussian indices
    const gpu::Buffer& offsets;  // n: inclusive scan of the depth-ordered tile counts
    const gpu::Buffer& bin_records;  // n SplatBinRecord in depth order (splat_sorted_counts)
    uint64_t n, instances;       // instances = offsets[n - 1] > 0
    uint32_t grid_x, tiles;
    bool cull;        // exact tile culling, else whole rects
    uint32_t chunks;  // from chunks_for
    uint32_t tile_y0 = 0;  // a band's first tile row (SplatFrame::tile_y0)
  };

  // Records the binning: values[0..instances) and ranges[0..tiles) (uvec2), and
  // incomplete[0] (uint32) != 0 when a walk was cut short (the results are then invalid).
  // The caller orders the inputs before and the outputs after with barriers.
  void record(gpu::CommandList& cmd, const Frame& f, const gpu::Buffer& values, const gpu::Buffer& ranges,
              const gpu::Buffer& incomplete);

  uint64_t bytes() const;  // device memory of the counters and the scan scratch

 private:
  gpu::Context& ctx_;
  gpu::Program& count_;
  gpu::Program& emit_;
  gpu::Program& totals_;
  gpu::Program& offsets_;
  kernels::PrefixScan scan_;
  gpu::Buffer counts_, cursors_, totals_buf_, tile_first_, scan_scratch_;
};

}  // namespace icube::splat
