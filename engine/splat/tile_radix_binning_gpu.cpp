// The shared tile-binning sequence; see tile_radix_binning_gpu.h.
#include "splat/tile_radix_binning_gpu.h"

#include "splat/tile_ranges_gpu.h"

#include <stdexcept>
#include <utility>

namespace icube::splat {

TileRadixBinning::TileRadixBinning(gpu::Context& ctx, kernels::KeyWidth width, std::string name)
    : ctx_(ctx), width_(width), name_(std::move(name)), scan_(ctx), sort_(ctx, width) {}

void TileRadixBinning::reserve_items(uint64_t items) {
  gpu::ensure_capacity(ctx_, counts_, items * 4, name_ + "-counts");
  gpu::ensure_capacity(ctx_, offsets_, items * 4, name_ + "-offsets");
  gpu::ensure_capacity(ctx_, scan_scratch_, kernels::PrefixScan::scratch_elements(items) * 4, name_ + "-scan-scratch");
}

void TileRadixBinning::record_scan(gpu::CommandList& cmd, uint64_t items, const gpu::BufferBinding& total) {
  if (items == 0) throw std::logic_error(name_ + " binning: record_scan needs at least one item");
  scan_.record(cmd, counts_, offsets_, items, kernels::ScanKind::Inclusive, &scan_scratch_);
  cmd.barrier(gpu::deps::kComputeToTransfer);  // the copy reads the last offset
  cmd.copy_buffer(offsets_.binding((items - 1) * 4, 4), total);
}

void TileRadixBinning::reserve_instances(uint64_t instances) {
  const uint64_t key_bytes = 4ull * key_words();
  // The instance emitters write the keys through one binding (the sort itself runs in windows).
  const uint64_t most = std::min<uint64_t>(ctx_.info().max_storage_buffer_range / key_bytes, sort_.max_elements());
  if (instances > most)
    throw std::runtime_error(name_ + ": " + std::to_string(instances) + " tile instances in one frame, over the " +
                             std::to_string(most) + " this device takes (one storage binding of " +
                             std::to_string(key_bytes) + "-byte keys); cast fewer or smaller Gaussians per frame");
  const uint64_t n = std::max<uint64_t>(instances, 1);
  gpu::ensure_capacity(ctx_, keys_, n * key_bytes, name_ + "-keys");
  gpu::ensure_capacity(ctx_, values_, n * 4, name_ + "-values");
  if (instances > 0 && (!sort_scratch_ || sort_scratch_->capacity < instances))
    sort_scratch_ = std::make_unique<kernels::RadixSortScratch>(ctx_, instances + instances / 2, width_);
}

void TileRadixBinning::record_sort_ranges(gpu::CommandList& cmd, uint64_t instances, uint32_t key_bits,
                                          gpu::Program& ranges_program, const gpu::Buffer& ranges, uint32_t tiles) {
  if (instances > 0) sort_.record(cmd, keys_, values_, instances, *sort_scratch_, key_bits);
  record_tile_ranges(cmd, ranges_program, keys_, key_words(), instances, ranges, tiles);
}

uint64_t TileRadixBinning::bytes() const {
  uint64_t s = 0;
  for (const gpu::Buffer* b : {&counts_, &offsets_, &scan_scratch_, &keys_, &values_}) s += b->valid() ? b->size() : 0;
  if (sort_scratch_)
    s += sort_scratch_->keys.size() + sort_scratch_->values.size() + sort_scratch_->histogram.size() +
         sort_scratch_->scan_scratch.size();
  return s;
}

}  // namespace icube::splat
