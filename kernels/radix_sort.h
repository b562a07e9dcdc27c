// Stable key-value LSD radix sort on the GPU: uint32 or uint64 keys, uint32 values.
//
// 8-bit digits, one pass per digit of the low `key_bits` bits (4 passes for
// 32-bit keys, up to 8 for 64-bit). Each pass: radix_count (per-tile digit
// histograms, digit-major) -> exclusive PrefixScan of the histogram ->
// radix_scatter (stable ranks from subgroup ballots). One workgroup is one
// subgroup, so the kernels are correct for any subgroup size up to 128 and do
// not depend on forward progress between workgroups.
//
// 64-bit keys are what the splatting rasterizer sorts: tile id in the high
// word, float depth bits in the low word (positive floats order like their bits).
// Pass key_bits = 32 + bits(tile id) to skip empty high digits.
//
// Arrays over one storage binding are sorted in windows of whole tiles: each pass
// counts per source window and scatters once per (source, destination) window
// pair, each dispatch writing only its destination window (the same sort; S x D
// scatter reads where S = D windows). Limits: the digit-major histogram (1 KiB
// per 4096-element tile) must fit one binding (537 M keys at 128 MiB) and n <
// 2^32 - 4096; larger inputs fail with a clear message before any work.
//
// Shaders: shaders/radix_count{32,64}.comp, shaders/radix_scatter{32,64}.comp.
// Tests: tests/primitives/test_radix_sort.cpp. Benchmark: bench/bench_primitives.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/prefix_scan.h"
#include "kernels/subgroup_ops.h"

#include <cstdint>
#include <vector>

namespace icube::kernels {

enum class KeyWidth { Bits32 = 32, Bits64 = 64 };

// Temporary buffers for sorting up to `capacity` elements.
struct RadixSortScratch {
  RadixSortScratch(gpu::Context& ctx, uint64_t capacity, KeyWidth width);
  uint64_t capacity;
  KeyWidth width;
  gpu::Buffer keys;
  gpu::Buffer values;
  gpu::Buffer histogram;
  gpu::Buffer scan_scratch;
};

class RadixSort {
 public:
  // `ops`: how a batch finds the lanes holding its digit (primitives/radix_common.glsl): eight subgroup
  // ballots, or constant-index shuffles of the lanes' digits (subgroups of at most 32 lanes);
  // both give the same sort.
  RadixSort(gpu::Context& ctx, KeyWidth width, SubgroupOps ops = SubgroupOps::Auto);

  KeyWidth width() const { return width_; }
  // Largest n one sort accepts on this device.
  uint64_t max_elements() const;
  // The element windows the keys and values of an n-element sort are bound in (one when they fit).
  std::vector<gpu::ElementWindow> windows(uint64_t n) const;

  // Records a stable sort of (keys, values)[0..n) by the low `key_bits` bits
  // of the key (0 = all bits); the result is left in `keys`/`values`.
  // The caller orders the inputs before and the outputs after with barriers;
  // the passes inside are separated by explicit barriers.
  void record(gpu::CommandList& cmd, const gpu::Buffer& keys, const gpu::Buffer& values, uint64_t n,
              RadixSortScratch& scratch, uint32_t key_bits = 0);

  // Convenience: allocates scratch, submits and waits.
  void run(const gpu::Buffer& keys, const gpu::Buffer& values, uint64_t n, uint32_t key_bits = 0);

 private:
  gpu::Context& ctx_;
  KeyWidth width_;
  gpu::Program& count_;
  gpu::Program& scatter_;
  PrefixScan scan_;
};

// CPU reference: std::stable_sort of (key, value) pairs by the low key_bits of the key.
void radix_sort_cpu(std::vector<uint32_t>& keys, std::vector<uint32_t>& values, uint32_t key_bits = 32);
void radix_sort_cpu(std::vector<uint64_t>& keys, std::vector<uint32_t>& values, uint32_t key_bits = 64);

}  // namespace icube::kernels
