// Counting-sort tile binning of the splatting rasterizer; see tile_binning_gpu.h.
#include "splat/tile_binning_gpu.h"

#include "gpu/context.h"
#include "shared/splat_params.h"

#include <algorithm>
#include <cstdlib>
#include <string>
#include <thread>

namespace icube::splat {

namespace {
constexpr uint32_t kLocal = 64;  // splat_bin_offsets: any multiple of the subgroup size

// The walks run one subgroup per workgroup, so the C / subgroup-size workgroups spread over
// the device's threads.
gpu::SpecConstants walk_spec(const gpu::Context& ctx, bool emit) {
  return gpu::SpecConstants{}.set(0, ctx.subgroup_size() /* local_size_x */).set(1, emit /* EMIT */);
}
}  // namespace

uint64_t TileBinningGpu::device_threads() {
  if (const char* e = std::getenv("LP_NUM_THREADS"); e && *e) {
    try {
      const unsigned long v = std::stoul(e);
      if (v > 0) return v;
    } catch (const std::exception&) {
    }
  }
  return std::max(1u, std::thread::hardware_concurrency());
}

uint64_t TileBinningGpu::chunk_groups(uint64_t threads) {
  return std::max<uint64_t>(kMinChunkGroups, kChunkGroupsPerThread * threads);
}

TileBinningGpu::TileBinningGpu(gpu::Context& ctx)
    : ctx_(ctx),
      count_(ctx.program("splat/bin_chunks", walk_spec(ctx, false))),
      emit_(ctx.program("splat/bin_chunks", walk_spec(ctx, true))),
      totals_(ctx.program("splat/bin_offsets", gpu::SpecConstants{}.set(0, kLocal /* local_size_x */).set(1, 0u /* STAGE */))),
      offsets_(ctx.program("splat/bin_offsets", gpu::SpecConstants{}.set(0, kLocal /* local_size_x */).set(1, 1u /* STAGE */))),
      scan_(ctx) {}

uint32_t TileBinningGpu::chunks_for(uint64_t instances, uint32_t tiles, uint32_t requested) const {
  const uint64_t sg = std::max<uint32_t>(1, ctx_.subgroup_size());
  uint64_t c = requested;
  if (!c) {
    c = std::max<uint64_t>(chunk_groups(device_threads()) * sg, gpu::div_up(instances, kMaxInstancesPerChunk));
    c = gpu::align_up(c, sg);  // whole subgroups
  }
  const uint64_t max_counters = std::min<uint64_t>({ctx_.info().max_storage_buffer_range / 4,
                                                     ctx_.info().max_texel_buffer_elements, UINT32_MAX});
  if (c > kMaxChunks || c * std::max<uint32_t>(1, tiles) > max_counters) return 0;
  return static_cast<uint32_t>(c);
}

void TileBinningGpu::record(gpu::CommandList& cmd, const Frame& f, const gpu::Buffer& values, const gpu::Buffer& ranges,
                            const gpu::Buffer& incomplete) {
  const uint64_t tc = uint64_t{f.tiles} * f.chunks, tiles = f.tiles;
  gpu::ensure_capacity(ctx_, counts_, tc * 4, "splat-bin-counts");
  gpu::ensure_capacity(ctx_, cursors_, tc * 4, "splat-bin-cursors");
  gpu::ensure_capacity(ctx_, totals_buf_, tiles * 4, "splat-bin-tile-totals");
  gpu::ensure_capacity(ctx_, tile_first_, tiles * 4, "splat-bin-tile-first");
  gpu::ensure_capacity(ctx_, scan_scratch_, kernels::PrefixScan::scratch_elements(tiles) * 4, "splat-bin-scan-scratch");
  const uint64_t n = f.n;
  const shader::SplatBinParams p{static_cast<uint32_t>(n),
                                 f.grid_x,
                                 f.chunks,
                                 static_cast<uint32_t>(gpu::div_up(f.instances, f.chunks)),
                                 f.cull ? 1u : 0u,
                                 f.tiles,
                                 static_cast<uint32_t>(f.instances),
                                 f.tile_y0};
  auto walk = [&](gpu::Program& prog, const gpu::Buffer& counters, const gpu::BufferBinding& out) {
    cmd.dispatch(prog, {f.chunks}, p,
                 {f.order.texel_binding(VK_FORMAT_R32_UINT, 0, n * 4), f.offsets.texel_binding(VK_FORMAT_R32_UINT, 0, n * 4),
                  f.bin_records.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, n * sizeof(shader::SplatBinRecord)),
                  counters.binding(0, tc * 4), out, incomplete.binding(0, 4)});
  };
  auto offsets = [&](gpu::Program& prog) {
    cmd.dispatch(prog, {tiles}, p,
                 {counts_.texel_binding(VK_FORMAT_R32_UINT, 0, tc * 4), totals_buf_.binding(0, tiles * 4),
                  tile_first_.binding(0, tiles * 4), cursors_.binding(0, tc * 4), ranges.binding(0, tiles * 8)});
  };
  cmd.fill_buffer(counts_.binding(0, tc * 4), 0u);
  cmd.fill_buffer(incomplete.binding(0, 4), 0u);
  cmd.barrier(gpu::deps::kTransferToCompute);  // the count walk increments the zeroed counters
  walk(count_, counts_, values.binding(0, 4) /* not written by the count walk */);
  cmd.barrier(gpu::deps::kComputeToCompute);  // the tile totals read the counts
  offsets(totals_);
  cmd.barrier(gpu::deps::kComputeToCompute);  // the scan reads the tile totals
  scan_.record(cmd, totals_buf_, tile_first_, tiles, kernels::ScanKind::Exclusive, &scan_scratch_);
  cmd.barrier(gpu::deps::kComputeToCompute);  // the cursors and ranges read the tiles' first slots
  offsets(offsets_);
  cmd.barrier(gpu::deps::kComputeToCompute);  // the emit walk advances the cursors
  walk(emit_, cursors_, values.binding(0, f.instances * 4));
}

uint64_t TileBinningGpu::bytes() const {
  uint64_t s = 0;
  for (const gpu::Buffer* b : {&counts_, &cursors_, &totals_buf_, &tile_first_, &scan_scratch_})
    s += b->valid() ? b->size() : 0;
  return s;
}

}  // namespace icube::splat
