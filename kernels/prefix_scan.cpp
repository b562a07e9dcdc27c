#include "kernels/prefix_scan.h"

#include "kernels/kernel_tiles.h"
#include "shared/primitives_params.h"

#include <algorithm>

namespace icube::kernels {

using gpu::align_up;

using gpu::Buffer;
using gpu::CommandList;

namespace {
// Scratch levels start at offsets aligned for any device (<= 256-byte alignment).
constexpr uint64_t kLevelAlignElems = 64;
}  // namespace

PrefixScan::PrefixScan(gpu::Context& ctx)
    : ctx_(ctx),
      tile_sums_(ctx.program("primitives/scan_tile_sums", subgroup_tile_spec(ctx))),
      tiles_(ctx.program("primitives/scan_tiles", subgroup_tile_spec(ctx))) {}

uint64_t PrefixScan::scratch_elements(uint64_t n) {
  uint64_t total = 0;
  for (uint64_t tiles = tiles_for(n); tiles > 1; tiles = tiles_for(tiles)) total += align_up(tiles, kLevelAlignElems);
  return total;
}

void PrefixScan::record(CommandList& cmd, const Buffer& in, const Buffer& out, uint64_t n, ScanKind kind,
                        const Buffer* scratch, uint64_t scratch_offset_elems) {
  if (n == 0) return;
  if (n > in.size() / 4 || n > out.size() / 4)
    throw std::invalid_argument("prefix scan: " + std::to_string(n) + " elements exceed the buffers");
  uint64_t need = scratch_elements(n);
  if (need && (!scratch || scratch->size() / 4 < scratch_offset_elems + need))
    throw std::invalid_argument("prefix scan: scratch must hold " + std::to_string(need) + " uint32");
  if (scratch_offset_elems % kLevelAlignElems)
    throw std::invalid_argument("prefix scan: scratch offset must be a multiple of 64 elements");
  record_level(cmd, in, 0, out, 0, n, kind, scratch, scratch_offset_elems);
}

void PrefixScan::record_level(CommandList& cmd, const Buffer& in, uint64_t in_offset, const Buffer& out,
                              uint64_t out_offset, uint64_t n, ScanKind kind, const Buffer* scratch,
                              uint64_t scratch_offset) {
  const uint64_t tiles = tiles_for(n);
  shader::ScanParams params{};
  params.inclusive = kind == ScanKind::Inclusive ? 1u : 0u;
  if (tiles == 1) {
    params.n = static_cast<uint32_t>(n);
    params.has_prefix = 0;
    gpu::BufferBinding src = in.binding(in_offset * 4, n * 4);
    cmd.dispatch(tiles_, {threads_for_tiles(ctx_, 1)}, params,
                 {src, out.binding(out_offset * 4, n * 4), gpu::null_binding() /* tile_prefix: has_prefix = 0 */});
    return;
  }
  const gpu::BufferBinding sums = scratch->binding(scratch_offset * 4, tiles * 4);
  const auto windows = gpu::storage_windows(ctx_.info(), n, 4, kTileElements);
  for (const gpu::ElementWindow& w : windows) {
    params.n = static_cast<uint32_t>(w.count);
    params.tile_base = static_cast<uint32_t>(w.first / kTileElements);
    cmd.dispatch(tile_sums_, {threads_for_tiles(ctx_, tiles_for(w.count))}, params,
                 {in.binding((in_offset + w.first) * 4, w.count * 4), sums});
  }
  cmd.barrier(gpu::deps::kComputeToCompute);  // the tile sums are scanned next
  record_level(cmd, *scratch, scratch_offset, *scratch, scratch_offset, tiles, ScanKind::Exclusive, scratch,
               scratch_offset + align_up(tiles, kLevelAlignElems));
  cmd.barrier(gpu::deps::kComputeToCompute);  // every tile reads its scanned carry-in
  params.has_prefix = 1;
  for (const gpu::ElementWindow& w : windows) {
    params.n = static_cast<uint32_t>(w.count);
    params.tile_base = static_cast<uint32_t>(w.first / kTileElements);
    cmd.dispatch(tiles_, {threads_for_tiles(ctx_, tiles_for(w.count))}, params,
                 {in.binding((in_offset + w.first) * 4, w.count * 4),
                  out.binding((out_offset + w.first) * 4, w.count * 4), sums});
  }
}

void PrefixScan::run(const Buffer& in, const Buffer& out, uint64_t n, ScanKind kind) {
  uint64_t need = scratch_elements(n);
  Buffer scratch;
  if (need) scratch = Buffer(ctx_, need * 4, gpu::MemoryUsage::DeviceLocal, "scan-scratch");
  ctx_.submit_and_wait([&](CommandList& cmd) { record(cmd, in, out, n, kind, need ? &scratch : nullptr); });
}

std::vector<uint32_t> prefix_scan_cpu(const std::vector<uint32_t>& in, ScanKind kind) {
  std::vector<uint32_t> out(in.size());
  uint32_t acc = 0;
  for (size_t i = 0; i < in.size(); ++i) {
    if (kind == ScanKind::Exclusive) out[i] = acc;
    acc += in[i];
    if (kind == ScanKind::Inclusive) out[i] = acc;
  }
  return out;
}

}  // namespace icube::kernels
