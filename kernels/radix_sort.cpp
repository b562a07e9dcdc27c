#include "kernels/radix_sort.h"

#include "kernels/kernel_tiles.h"
#include "shared/primitives_params.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

namespace icube::kernels {

using gpu::Buffer;
using gpu::CommandList;

namespace {
constexpr uint32_t kRadixSize = 256;
uint32_t key_bytes(KeyWidth w) { return w == KeyWidth::Bits64 ? 8u : 4u; }

// Digit matches by constant-index shuffles (primitives/radix_common.glsl RADIX_LANES = the subgroup size)
// or by eight ballots (0).
gpu::SpecConstants radix_spec(const gpu::Context& ctx, SubgroupOps ops) {
  gpu::SpecConstants s = subgroup_tile_spec(ctx);
  s.set(kSpecRadixLanes, shuffle_lanes(ctx, ops, ctx.subgroup_size() <= 32, "radix sort"));
  return s;
}
}  // namespace

RadixSortScratch::RadixSortScratch(gpu::Context& ctx, uint64_t cap, KeyWidth key_width)
    : capacity(std::max<uint64_t>(cap, 1)),
      width(key_width),
      keys(ctx, capacity * key_bytes(key_width), gpu::MemoryUsage::DeviceLocal, "radix-keys-tmp"),
      values(ctx, capacity * 4, gpu::MemoryUsage::DeviceLocal, "radix-values-tmp"),
      histogram(ctx, kRadixSize * tiles_for(capacity) * 4, gpu::MemoryUsage::DeviceLocal, "radix-histogram"),
      scan_scratch(ctx, std::max<uint64_t>(PrefixScan::scratch_elements(kRadixSize * tiles_for(capacity)), 1) * 4,
                   gpu::MemoryUsage::DeviceLocal, "radix-scan-scratch") {}

RadixSort::RadixSort(gpu::Context& ctx, KeyWidth width, SubgroupOps ops)
    : ctx_(ctx),
      width_(width),
      count_(ctx.program(width == KeyWidth::Bits64 ? "primitives/radix_count64" : "primitives/radix_count32", radix_spec(ctx, ops))),
      scatter_(ctx.program(width == KeyWidth::Bits64 ? "primitives/radix_scatter64" : "primitives/radix_scatter32", radix_spec(ctx, ops))),
      scan_(ctx) {
  if (ctx.subgroup_size() > 128 || kTileElements % ctx.subgroup_size())
    throw std::runtime_error("radix sort needs a subgroup size that divides " + std::to_string(kTileElements) +
                             " and is at most 128; device has " + std::to_string(ctx.subgroup_size()));
}

uint64_t RadixSort::max_elements() const {
  // Keys and values go in windows of whole tiles; the digit-major histogram (256 words per tile,
  // scanned in windows) is bound whole.
  const uint64_t by_histogram = ctx_.info().max_storage_buffer_range / (kRadixSize * 4) * kTileElements;
  return std::min<uint64_t>({by_histogram, uint64_t{UINT32_MAX} - kTileElements});
}

std::vector<gpu::ElementWindow> RadixSort::windows(uint64_t n) const {
  // Whole tiles of keys (the wider array); the values' windows cover the same elements. Arrays
  // that fit one binding are one window, however small the binding.
  if (n * key_bytes(width_) <= ctx_.info().max_storage_buffer_range) return {{0, n}};
  return gpu::storage_windows(ctx_.info(), n, key_bytes(width_), kTileElements);
}

void RadixSort::record(CommandList& cmd, const Buffer& keys, const Buffer& values, uint64_t n,
                       RadixSortScratch& scratch, uint32_t key_bits) {
  if (n == 0) return;
  const uint32_t kb = key_bytes(width_);
  const uint32_t total_bits = kb * 8;
  if (key_bits == 0 || key_bits > total_bits) key_bits = total_bits;
  if (n > max_elements())
    throw std::invalid_argument("radix sort: " + std::to_string(n) + " keys are more than one sort takes (" +
                                std::to_string(max_elements()) + " on " + ctx_.info().name +
                                ": its histogram must fit one storage binding); sort fewer by " +
                                std::to_string(n - max_elements()));
  if (n > scratch.capacity) throw std::invalid_argument("radix sort: scratch capacity is smaller than n");
  if (scratch.width != width_) throw std::invalid_argument("radix sort: scratch was made for another key width");
  if (keys.size() < n * kb || values.size() < n * 4) throw std::invalid_argument("radix sort: buffers smaller than n");

  const uint64_t tiles = tiles_for(n);
  const uint64_t hist_n = kRadixSize * tiles;
  const uint32_t passes = (key_bits + 7) / 8;
  const std::vector<gpu::ElementWindow> win = windows(n);
  const Buffer* src_k = &keys;
  const Buffer* src_v = &values;
  const Buffer* dst_k = &scratch.keys;
  const Buffer* dst_v = &scratch.values;
  shader::RadixParams params{};
  params.n = static_cast<uint32_t>(n);
  params.num_tiles = static_cast<uint32_t>(tiles);
  const gpu::BufferBinding hist = scratch.histogram.binding(0, hist_n * 4);
  for (uint32_t pass = 0; pass < passes; ++pass) {
    params.shift = pass * 8;
    params.digit_mask = (1u << std::min(8u, key_bits - pass * 8)) - 1u;
    for (const gpu::ElementWindow& s : win) {
      params.tile_first = static_cast<uint32_t>(s.first / kTileElements);
      cmd.dispatch(count_, {threads_for_tiles(ctx_, tiles_for(s.count))}, params,
                   {src_k->binding(s.first * kb, s.count * kb), hist});
    }
    cmd.barrier(gpu::deps::kComputeToCompute);  // the scan reads the histogram
    scan_.record(cmd, scratch.histogram, scratch.histogram, hist_n, ScanKind::Exclusive, &scratch.scan_scratch);
    cmd.barrier(gpu::deps::kComputeToCompute);  // the scatter reads the digit offsets
    // Every source window scatters into every destination window (a tile's keys land anywhere);
    // the dispatches write disjoint elements, so they need no barriers between them.
    for (const gpu::ElementWindow& s : win)
      for (const gpu::ElementWindow& d : win) {
        params.tile_first = static_cast<uint32_t>(s.first / kTileElements);
        params.dst_first = static_cast<uint32_t>(d.first);
        params.dst_count = static_cast<uint32_t>(d.count);
        cmd.dispatch(scatter_, {threads_for_tiles(ctx_, tiles_for(s.count))}, params,
                     {src_k->binding(s.first * kb, s.count * kb), src_v->binding(s.first * 4, s.count * 4), hist,
                      dst_k->binding(d.first * kb, d.count * kb), dst_v->binding(d.first * 4, d.count * 4)});
      }
    // The next pass reads the scattered keys and rewrites the histogram.
    cmd.barrier(gpu::deps::kComputeToCompute);
    std::swap(src_k, dst_k);
    std::swap(src_v, dst_v);
  }
  if (src_k != &keys) {  // odd number of passes: the result is in the scratch buffers
    cmd.barrier(gpu::deps::kComputeToTransfer);
    cmd.copy_buffer(src_k->binding(0, n * kb), keys.binding(0, n * kb));
    cmd.copy_buffer(src_v->binding(0, n * 4), values.binding(0, n * 4));
    cmd.barrier(gpu::deps::kTransferToCompute);  // so callers' compute barriers chain after the copy
  }
}

void RadixSort::run(const Buffer& keys, const Buffer& values, uint64_t n, uint32_t key_bits) {
  if (n == 0) return;
  RadixSortScratch scratch(ctx_, n, width_);
  ctx_.submit_and_wait([&](CommandList& cmd) { record(cmd, keys, values, n, scratch, key_bits); });
}

template <class K>
static void stable_sort_pairs(std::vector<K>& keys, std::vector<uint32_t>& values, uint32_t key_bits) {
  if (keys.size() != values.size()) throw std::invalid_argument("radix_sort_cpu: keys and values differ in length");
  const K mask = key_bits >= sizeof(K) * 8 ? ~K(0) : (K(1) << key_bits) - 1;
  std::vector<size_t> order(keys.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return (keys[a] & mask) < (keys[b] & mask); });
  std::vector<K> k(keys.size());
  std::vector<uint32_t> v(values.size());
  for (size_t i = 0; i < order.size(); ++i) {
    k[i] = keys[order[i]];
    v[i] = values[order[i]];
  }
  keys.swap(k);
  values.swap(v);
}

void radix_sort_cpu(std::vector<uint32_t>& keys, std::vector<uint32_t>& values, uint32_t key_bits) {
  stable_sort_pairs(keys, values, key_bits);
}
void radix_sort_cpu(std::vector<uint64_t>& keys, std::vector<uint32_t>& values, uint32_t key_bits) {
  stable_sort_pairs(keys, values, key_bits);
}

}  // namespace icube::kernels
