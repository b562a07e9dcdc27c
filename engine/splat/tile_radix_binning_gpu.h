// The tile-binning sequence shared by the splatting rasterizer's radix path and
// the Gaussian LiDAR: per-item tile counts (the caller's kernel) -> inclusive
// PrefixScan into instance offsets -> the instance total copied to the host ->
// (key, value) per instance at the scan offsets (the caller's emit kernel) ->
// stable RadixSort of the key bits -> per-tile [first, end) ranges
// (record_tile_ranges, shaders/splat/ranges.comp).
//
// It owns the buffers of that sequence (counts, offsets, scan scratch, keys,
// values, sort scratch), grown on demand and reused across frames. Its two
// record stages go into the caller's command lists with the one host readback
// between them (the instance total sizes keys and values):
//   reserve_items(n); [caller: count kernel writing counts()] ; record_scan(cmd, n, total)
//   -- submit, wait, read the total --
//   reserve_instances(inst); [caller: emit kernel writing keys()/values() at offsets()]
//   record_sort_ranges(cmd, ...)
// Barriers between the caller's kernels and these stages are the caller's; the
// ones inside a stage are written there.
// Tests: tests/splat/test_splat.cpp, tests/splat/test_lidar_gaussians.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/prefix_scan.h"
#include "kernels/radix_sort.h"

#include <cstdint>
#include <memory>
#include <string>

namespace icube::splat {

class TileRadixBinning {
 public:
  // `name` prefixes the buffer names ("splat", "lidar-gs"); keys are 32-bit tile ids or 64-bit
  // (tile << 32 | payload) keys.
  TileRadixBinning(gpu::Context& ctx, kernels::KeyWidth width, std::string name);

  // Counts, offsets and scan scratch for `items` items.
  void reserve_items(uint64_t items);
  // Records the inclusive scan counts -> offsets over `items` > 0 items, then (after a barrier)
  // the copy of offsets[items - 1], the instance total, into the 4 bytes at `total`.
  void record_scan(gpu::CommandList& cmd, uint64_t items, const gpu::BufferBinding& total);

  // Keys, values and sort scratch for `instances` (at least one of each is allocated). Throws
  // when they exceed one storage binding or the radix sort's limit.
  void reserve_instances(uint64_t instances);
  // Records the stable sort of keys()/values() over their low `key_bits` bits and the tile
  // ranges (key_words: 1 = 32-bit tile ids, 2 = tile id in the high word) into `ranges`.
  void record_sort_ranges(gpu::CommandList& cmd, uint64_t instances, uint32_t key_bits, gpu::Program& ranges_program,
                          const gpu::Buffer& ranges, uint32_t tiles);

  const gpu::Buffer& counts() const { return counts_; }
  const gpu::Buffer& offsets() const { return offsets_; }
  const gpu::Buffer& keys() const { return keys_; }
  const gpu::Buffer& values() const { return values_; }
  uint32_t key_words() const { return width_ == kernels::KeyWidth::Bits64 ? 2u : 1u; }
  uint64_t max_instances() const { return sort_.max_elements(); }
  uint64_t bytes() const;  // device memory held

 private:
  gpu::Context& ctx_;
  kernels::KeyWidth width_;
  std::string name_;
  kernels::PrefixScan scan_;
  kernels::RadixSort sort_;
  gpu::Buffer counts_, offsets_, scan_scratch_, keys_, values_;
  std::unique_ptr<kernels::RadixSortScratch> sort_scratch_;
};

}  // namespace icube::splat
