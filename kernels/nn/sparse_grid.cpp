// GPU sparse grid construction; see sparse_grid.h.
#include "kernels/nn/sparse_grid.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

namespace {

uint64_t at_least_4(uint64_t bytes) { return std::max<uint64_t>(bytes, 4); }

}  // namespace

SparseGridOps::SparseGridOps(gpu::Context& ctx)
    : ctx_(ctx),
      keep_(ctx.program("nn/sparse_keep")),
      children_(ctx.program("nn/sparse_children")),
      permute_(ctx.program("nn/sparse_permute")),
      gather_(ctx.program("nn/sparse_gather_rows")),
      coarse_keys_(ctx.program("nn/sparse_coarse_keys")),
      segments_(ctx.program("nn/sparse_segments")),
      coarse_rows_(ctx.program("nn/sparse_coarse_rows")),
      max_pool_(ctx.program("nn/sparse_max_pool")),
      lookup_(ctx.program("nn/sparse_lookup")),
      scan_(ctx),
      sort_(ctx, KeyWidth::Bits64),
      iota_(ctx) {}

void SparseGridOps::record_keep(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& logits, const gpu::Buffer& keep) {
  if (rows == 0) return;
  require_buffer("sparse keep", "logits", uint64_t{rows} * 8, logits);
  require_buffer("sparse keep", "keep", uint64_t{rows} * 4, keep);
  // Windows of rows: each channel's logits and the decisions bound at their own offsets (disjoint writes).
  const uint64_t fit = window_elements(ctx_);
  for (uint64_t r0 = 0; r0 < rows; r0 += fit) {
    const uint64_t n = std::min<uint64_t>(fit, rows - r0);
    const ElementWindow exists = element_window(ctx_, logits, r0, n), empty = element_window(ctx_, logits, rows + r0, n),
                        out = element_window(ctx_, keep, r0, n);
    shader::SparseGridParams pc{};
    pc.rows = static_cast<uint32_t>(n);
    pc.x_offset = exists.offset;
    pc.x1_offset = empty.offset;
    pc.y_offset = out.offset;
    cmd.dispatch(keep_, gpu::Threads{n}, pc, {exists.binding, empty.binding, out.binding});
  }
}

void SparseGridOps::record_children(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& ijk, const gpu::Buffer& keep,
                                    const gpu::Buffer& incl, const std::array<int32_t, 3>& f, const gpu::Buffer& child_ijk,
                                    const gpu::Buffer& parent, const gpu::Buffer& keys) {
  if (rows == 0) return;
  for (const int32_t v : f)
    if (v < 1 || v > 8) throw std::invalid_argument("sparse subdivide: factor " + std::to_string(v) + " (1 to 8)");
  const uint64_t F = uint64_t(f[0]) * f[1] * f[2];
  require_one_binding(ctx_, "sparse subdivide", "children coordinates", uint64_t{rows} * F * 3);
  shader::SparseGridParams pc{};
  pc.rows = rows;
  pc.factor_x = static_cast<uint32_t>(f[0]);
  pc.factor_y = static_cast<uint32_t>(f[1]);
  pc.factor_z = static_cast<uint32_t>(f[2]);
  cmd.dispatch(children_, gpu::Threads{uint64_t{rows} * F}, pc,
               {ijk.binding(0, uint64_t{rows} * 12), keep.binding(0, uint64_t{rows} * 4), incl.binding(0, uint64_t{rows} * 4),
                child_ijk.binding(0, child_ijk.size()), parent.binding(0, parent.size()), keys.binding(0, keys.size())});
}

void SparseGridOps::record_permute(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& perm, const gpu::Buffer& in_ijk,
                                   const gpu::Buffer& in_parent, const gpu::Buffer& out_ijk, const gpu::Buffer& out_parent) {
  if (rows == 0) return;
  shader::SparseGridParams pc{};
  pc.rows = rows;
  cmd.dispatch(permute_, gpu::Threads{rows}, pc,
               {perm.binding(0, uint64_t{rows} * 4), in_ijk.binding(0, uint64_t{rows} * 12), in_parent.binding(0, uint64_t{rows} * 4),
                out_ijk.binding(0, uint64_t{rows} * 12), out_parent.binding(0, uint64_t{rows} * 4)});
}

void SparseGridOps::record_gather_rows(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t in_rows, uint32_t channels,
                                       const gpu::Buffer& rows, uint32_t out_rows, const gpu::Buffer& y) {
  if (out_rows == 0 || channels == 0) return;
  if (in_rows == 0) throw std::invalid_argument("sparse gather: no input rows");
  require_buffer("sparse gather", "input", uint64_t{in_rows} * channels * 4, x);
  require_buffer("sparse gather", "output", uint64_t{out_rows} * channels * 4, y);
  require_buffer("sparse gather", "rows", uint64_t{out_rows} * 4, rows);
  // The input is read as texels (bounded by maxTexelBufferElements), the rows and the output through
  // storage bindings: windows of whole channels, or, when one output channel exceeds a binding, each
  // channel's output rows in windows (the rows binding at an aligned row).
  const uint64_t out_fit = window_elements(ctx_);
  const uint64_t in_fit = std::min<uint64_t>(ctx_.info().max_texel_buffer_elements, UINT32_MAX / 2) -
                          std::max<uint64_t>(4, ctx_.info().min_texel_buffer_offset_alignment) / 4;
  if (in_rows > in_fit)
    throw std::invalid_argument("sparse gather: one channel of " + std::to_string(in_rows) + " rows exceeds the " +
                                std::to_string(in_fit) + " texels of one texel buffer; use fewer voxels per chunk");
  const uint64_t per_window = std::min(in_fit / in_rows, out_fit / out_rows);
  auto dispatch = [&](uint64_t c0, uint64_t cw, uint64_t r0, uint64_t rn) {
    const ElementWindow xw = texel_window(ctx_, x, c0 * in_rows, cw * in_rows);
    const ElementWindow yw = element_window(ctx_, y, c0 * out_rows + r0, cw * rn);
    shader::SparseGridParams pc{};
    pc.rows = static_cast<uint32_t>(rn);
    pc.in_rows = in_rows;
    pc.channels = static_cast<uint32_t>(cw);
    pc.x_offset = xw.offset;
    pc.y_offset = yw.offset;
    cmd.dispatch(gather_, gpu::Threads{cw * rn}, pc, {xw.binding, rows.binding(r0 * 4, rn * 4), yw.binding});
  };
  if (per_window > 0) {
    for (uint64_t c0 = 0; c0 < channels; c0 += per_window)
      dispatch(c0, std::min<uint64_t>(per_window, channels - c0), 0, out_rows);
    return;
  }
  const uint64_t unit = gpu::aligned_element_unit(ctx_.info(), 4);
  const uint64_t row_window = out_fit / unit * unit;
  for (uint64_t c = 0; c < channels; ++c)
    for (uint64_t r0 = 0; r0 < out_rows; r0 += row_window) dispatch(c, 1, r0, std::min<uint64_t>(row_window, out_rows - r0));
}

SparseGridOps::Children SparseGridOps::subdivide(const gpu::Buffer& ijk, uint32_t rows, const gpu::Buffer& logits,
                                                 const std::array<int32_t, 3>& f) {
  Children out;
  if (rows == 0) {
    out.ijk = gpu::Buffer(ctx_, 12, gpu::MemoryUsage::DeviceLocal, "sparse-children-ijk");
    out.parent = gpu::Buffer(ctx_, 4, gpu::MemoryUsage::DeviceLocal, "sparse-children-parent");
    return out;
  }
  gpu::Buffer keep(ctx_, uint64_t{rows} * 4, gpu::MemoryUsage::DeviceLocal, "sparse-keep");
  gpu::Buffer incl(ctx_, uint64_t{rows} * 4, gpu::MemoryUsage::DeviceLocal, "sparse-keep-scan");
  const uint64_t scratch_n = PrefixScan::scratch_elements(rows);
  gpu::Buffer scratch(ctx_, at_least_4(scratch_n * 4), gpu::MemoryUsage::DeviceLocal, "sparse-scan-scratch");
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    record_keep(cmd, rows, logits, keep);
    cmd.barrier(gpu::deps::kComputeToCompute);
    scan_.record(cmd, keep, incl, rows, ScanKind::Inclusive, scratch_n ? &scratch : nullptr);
  });
  const uint32_t kept = gpu::download_vector<uint32_t>(ctx_, incl, 1, uint64_t{rows - 1} * 4)[0];
  const uint64_t F = uint64_t(f[0]) * f[1] * f[2], n = kept * F;
  if (n > UINT32_MAX / 3) throw std::invalid_argument("sparse subdivide: " + std::to_string(n) + " children are too many");
  out.rows = static_cast<uint32_t>(n);
  out.ijk = gpu::Buffer(ctx_, at_least_4(n * 12), gpu::MemoryUsage::DeviceLocal, "sparse-children-ijk");
  out.parent = gpu::Buffer(ctx_, at_least_4(n * 4), gpu::MemoryUsage::DeviceLocal, "sparse-children-parent");
  if (n == 0) return out;
  gpu::Buffer child_ijk(ctx_, n * 12, gpu::MemoryUsage::DeviceLocal, "sparse-children-unsorted");
  gpu::Buffer parent(ctx_, n * 4, gpu::MemoryUsage::DeviceLocal, "sparse-parents-unsorted");
  gpu::Buffer keys(ctx_, n * 8, gpu::MemoryUsage::DeviceLocal, "sparse-children-keys");
  gpu::Buffer perm(ctx_, n * 4, gpu::MemoryUsage::DeviceLocal, "sparse-children-order");
  RadixSortScratch sort_scratch(ctx_, n, KeyWidth::Bits64);
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    record_children(cmd, rows, ijk, keep, incl, f, child_ijk, parent, keys);
    iota_.record(cmd, perm, n);
    cmd.barrier(gpu::deps::kComputeToCompute);
    sort_.record(cmd, keys, perm, n, sort_scratch);
    cmd.barrier(gpu::deps::kComputeToCompute);
    cmd.barrier(gpu::deps::kTransferToCompute);  // an odd pass count ends the sort with a copy
    record_permute(cmd, static_cast<uint32_t>(n), perm, child_ijk, parent, out.ijk, out.parent);
  });
  return out;
}

SparseGridOps::Coarse SparseGridOps::coarsen(const gpu::Buffer& ijk, uint32_t rows, const std::array<int32_t, 3>& f) {
  for (const int32_t v : f)
    if (v < 1 || v > 8) throw std::invalid_argument("sparse max pool: factor " + std::to_string(v) + " (1 to 8)");
  Coarse c;
  c.fine_rows = rows;
  if (rows == 0) {
    c.ijk = gpu::Buffer(ctx_, 12, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-ijk");
    c.perm = gpu::Buffer(ctx_, 4, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-perm");
    c.begin = gpu::Buffer(ctx_, 4, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-begin");
    return c;
  }
  require_one_binding(ctx_, "sparse max pool", "coordinates", uint64_t{rows} * 3);
  gpu::Buffer keys(ctx_, uint64_t{rows} * 8, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-keys");
  c.perm = gpu::Buffer(ctx_, uint64_t{rows} * 4, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-perm");
  gpu::Buffer starts(ctx_, uint64_t{rows} * 4, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-starts");
  gpu::Buffer incl(ctx_, uint64_t{rows} * 4, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-scan");
  const uint64_t scratch_n = PrefixScan::scratch_elements(rows);
  gpu::Buffer scratch(ctx_, at_least_4(scratch_n * 4), gpu::MemoryUsage::DeviceLocal, "sparse-coarse-scan-scratch");
  RadixSortScratch sort_scratch(ctx_, rows, KeyWidth::Bits64);
  shader::SparseGridParams pc{};
  pc.rows = rows;
  pc.factor_x = static_cast<uint32_t>(f[0]);
  pc.factor_y = static_cast<uint32_t>(f[1]);
  pc.factor_z = static_cast<uint32_t>(f[2]);
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    cmd.dispatch(coarse_keys_, gpu::Threads{rows}, pc,
                 {ijk.binding(0, uint64_t{rows} * 12), keys.binding(0, uint64_t{rows} * 8), c.perm.binding(0, uint64_t{rows} * 4)});
    cmd.barrier(gpu::deps::kComputeToCompute);
    sort_.record(cmd, keys, c.perm, rows, sort_scratch);
    cmd.barrier(gpu::deps::kComputeToCompute);
    cmd.barrier(gpu::deps::kTransferToCompute);  // an odd pass count ends the sort with a copy
    cmd.dispatch(segments_, gpu::Threads{rows}, pc, {keys.binding(0, uint64_t{rows} * 8), starts.binding(0, uint64_t{rows} * 4)});
    cmd.barrier(gpu::deps::kComputeToCompute);
    scan_.record(cmd, starts, incl, rows, ScanKind::Inclusive, scratch_n ? &scratch : nullptr);
  });
  c.rows = gpu::download_vector<uint32_t>(ctx_, incl, 1, uint64_t{rows - 1} * 4)[0];
  c.ijk = gpu::Buffer(ctx_, uint64_t{c.rows} * 12, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-ijk");
  c.begin = gpu::Buffer(ctx_, uint64_t{c.rows} * 4, gpu::MemoryUsage::DeviceLocal, "sparse-coarse-begin");
  ctx_.submit_and_wait([&](gpu::CommandList& cmd) {
    cmd.dispatch(coarse_rows_, gpu::Threads{rows}, pc,
                 {ijk.binding(0, uint64_t{rows} * 12), c.perm.binding(0, uint64_t{rows} * 4), starts.binding(0, uint64_t{rows} * 4),
                  incl.binding(0, uint64_t{rows} * 4), c.begin.binding(0, uint64_t{c.rows} * 4), c.ijk.binding(0, uint64_t{c.rows} * 12)});
  });
  return c;
}

void SparseGridOps::record_max_pool(gpu::CommandList& cmd, const Coarse& c, const gpu::Buffer& x, uint32_t channels,
                                    const gpu::Buffer& y) {
  if (c.rows == 0 || channels == 0) return;
  require_buffer("sparse max pool", "input", uint64_t{c.fine_rows} * channels * 4, x);
  require_buffer("sparse max pool", "output", uint64_t{c.rows} * channels * 4, y);
  const uint64_t usable = window_elements(ctx_);
  const uint64_t per_window = usable / c.fine_rows;
  if (per_window == 0) throw std::invalid_argument("sparse max pool: one channel exceeds one storage binding");
  for (uint64_t c0 = 0; c0 < channels; c0 += per_window) {
    const uint64_t cw = std::min<uint64_t>(per_window, channels - c0);
    const ElementWindow xw = texel_window(ctx_, x, c0 * c.fine_rows, cw * c.fine_rows);
    const ElementWindow yw = element_window(ctx_, y, c0 * c.rows, cw * c.rows);
    shader::SparseGridParams pc{};
    pc.rows = c.rows;
    pc.in_rows = c.fine_rows;
    pc.channels = static_cast<uint32_t>(cw);
    pc.x_offset = xw.offset;
    pc.y_offset = yw.offset;
    cmd.dispatch(max_pool_, gpu::Threads{cw * c.rows}, pc,
                 {xw.binding, c.perm.binding(0, uint64_t{c.fine_rows} * 4), c.begin.binding(0, uint64_t{c.rows} * 4), yw.binding});
  }
}

void SparseGridOps::record_lookup(gpu::CommandList& cmd, uint32_t grid_rows, const gpu::Buffer& ijk, const gpu::Buffer& table,
                                  uint32_t table_size, uint32_t queries, const gpu::Buffer& query_ijk, const gpu::Buffer& rows) {
  if (queries == 0) return;
  require_buffer("sparse lookup", "queries", uint64_t{queries} * 12, query_ijk);
  require_buffer("sparse lookup", "rows", uint64_t{queries} * 4, rows);
  const shader::SparseHashParams pc{queries, table_size, 0, 0};
  cmd.dispatch(lookup_, gpu::Threads{queries}, pc,
               {ijk.binding(0, std::max<uint64_t>(12, uint64_t{grid_rows} * 12)), table.binding(0, uint64_t{table_size} * 4),
                query_ijk.binding(0, uint64_t{queries} * 12), rows.binding(0, uint64_t{queries} * 4)});
}

}  // namespace icube::kernels::nn
