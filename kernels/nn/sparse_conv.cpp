// Sparse kernel maps and submanifold convolution; see sparse_conv.h.
#include "kernels/nn/sparse_conv.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

namespace {

// Kernel-map rows one binding may hold: a multiple of the rows whose 108 bytes meet the binding-offset
// alignment, so every window starts aligned.
uint64_t kmap_window_rows(const gpu::Context& ctx) {
  const uint64_t row_bytes = uint64_t{NN_SPARSE_TAPS} * 4;
  const uint64_t unit = gpu::aligned_element_unit(ctx.info(), row_bytes);
  const uint64_t rows = ctx.info().max_storage_buffer_range / row_bytes / unit * unit;
  if (rows == 0)
    throw std::invalid_argument("sparse kernel map: one storage binding of " +
                                std::to_string(ctx.info().max_storage_buffer_range) + " bytes holds no aligned row window");
  return rows;
}

}  // namespace

SparseKernelMap::SparseKernelMap(gpu::Context& ctx)
    : ctx_(ctx), insert_(ctx.program("nn/sparse_hash_insert")), map_(ctx.program("nn/sparse_kernel_map")) {}

uint32_t SparseKernelMap::table_size(uint64_t rows) {
  uint64_t n = 64;
  while (n < 2 * rows) n *= 2;
  if (n > (uint64_t{1} << 31)) throw std::invalid_argument("sparse kernel map: " + std::to_string(rows) + " rows are too many");
  return static_cast<uint32_t>(n);
}

void SparseKernelMap::record_clear(gpu::CommandList& cmd, const gpu::Buffer& table, uint32_t table_size) {
  require_buffer("sparse kernel map", "hash table", uint64_t{table_size} * 4, table);
  cmd.fill_buffer(table.binding(0, uint64_t{table_size} * 4), 0u);
}

void SparseKernelMap::record_insert(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& ijk, const gpu::Buffer& table,
                                    uint32_t table_size) {
  if (rows == 0) return;
  if (table_size < 2 * uint64_t{rows} || (table_size & (table_size - 1)) != 0)
    throw std::invalid_argument("sparse kernel map: table of " + std::to_string(table_size) + " slots for " +
                                std::to_string(rows) + " rows (needs a power of two >= 2 x rows)");
  require_buffer("sparse kernel map", "coordinates", uint64_t{rows} * 12, ijk);
  require_buffer("sparse kernel map", "hash table", uint64_t{table_size} * 4, table);
  require_one_binding(ctx_, "sparse kernel map", "coordinates", uint64_t{rows} * 3);
  require_one_binding(ctx_, "sparse kernel map", "hash table", table_size);
  const shader::SparseHashParams pc{rows, table_size, 0, 0};
  cmd.dispatch(insert_, gpu::Threads{rows}, pc, {ijk.binding(0, uint64_t{rows} * 12), table.binding(0, uint64_t{table_size} * 4)});
}

void SparseKernelMap::record_map(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& ijk, const gpu::Buffer& table,
                                 uint32_t table_size, const gpu::Buffer& kmap) {
  if (rows == 0) return;
  const uint64_t entries = uint64_t{rows} * NN_SPARSE_TAPS;
  require_buffer("sparse kernel map", "kernel map", entries * 4, kmap);
  const uint64_t window = kmap_window_rows(ctx_);
  for (uint64_t r0 = 0; r0 < rows; r0 += window) {  // row windows when the map exceeds one binding
    const uint64_t count = std::min<uint64_t>(window, rows - r0);
    const shader::SparseHashParams pc{rows, table_size, static_cast<uint32_t>(r0), static_cast<uint32_t>(count)};
    cmd.dispatch(map_, gpu::Threads{count * NN_SPARSE_TAPS}, pc,
                 {ijk.binding(0, uint64_t{rows} * 12), table.binding(0, uint64_t{table_size} * 4),
                  kmap.binding(r0 * NN_SPARSE_TAPS * 4, count * NN_SPARSE_TAPS * 4)});
  }
}

const char* SparseConv3d::shader_name(Conv3dPath path, bool f16_weights) {
  static const char* const kNames[4][2] = {{"nn/sparse_conv", "nn/sparse_conv_f16w"},
                                           {"nn/sparse_conv_tiled", "nn/sparse_conv_tiled_f16w"},
                                           {"nn/sparse_conv_coopmat", "nn/sparse_conv_coopmat_f16w"},
                                           {"nn/sparse_conv_coopmat_emulated", "nn/sparse_conv_coopmat_emulated_f16w"}};
  return kNames[static_cast<int>(path)][f16_weights ? 1 : 0];
}

SparseConv3d::SparseConv3d(gpu::Context& ctx) : ctx_(ctx) {
  // Create the default paths' programs now, so pipeline creation does not land inside a timed forward.
  for (const bool f16 : {false, true}) ctx.program(shader_name(path(f16), f16));
}

Conv3dPath SparseConv3d::path(bool f16_weights) const {
  return forced_path_ ? *forced_path_ : default_conv3d_path(ctx_.info(), f16_weights);
}

void SparseConv3d::record(gpu::CommandList& cmd, const SparseConvShape& s, const gpu::Buffer& x, const gpu::Buffer& kmap,
                          const gpu::Buffer& w, const gpu::Buffer* bias, const gpu::Buffer& y) {
  if (s.rows == 0 || s.in_channels == 0 || s.out_channels == 0) return;
  const uint64_t N = s.rows;
  const uint64_t co_vec4s = gpu::div_up(s.out_channels, NN_CONV_CO_TILE) * (NN_CONV_CO_TILE / 4);
  const uint64_t w_bytes = uint64_t{s.in_channels} * NN_SPARSE_TAPS * co_vec4s * (s.f16_weights ? 8 : 16);
  const uint64_t x_element = s.f16_input ? 2 : 4;
  require_buffer("sparse conv", "input", uint64_t{s.in_channels} * N * x_element, x);
  require_buffer("sparse conv", "output", uint64_t{s.out_channels} * N * 4, y);
  require_buffer("sparse conv", "kernel map", N * NN_SPARSE_TAPS * 4, kmap);
  require_buffer("sparse conv", "packed weights", w_bytes, w);
  if (bias) require_buffer("sparse conv", "bias", uint64_t{s.out_channels} * 4, *bias);

  const Conv3dPath sparse_path = path(s.f16_weights);
  if (const std::string why = conv3d_path_unavailable(sparse_path, ctx_.info()); !why.empty())
    throw std::invalid_argument(std::string("sparse conv: the ") + conv3d_path_name(sparse_path) + " path: " + why);
  gpu::Program& program = ctx_.program(shader_name(sparse_path, s.f16_weights));
  // Rows and output channels per workgroup: the register tile's NN_SPARSE_ROWS x NN_SPARSE_GROUP rows and
  // 8 channels, the tiled and cooperative-matrix kernels' 64 x 64 blocks.
  const bool register_tile = sparse_path == Conv3dPath::kRegisterTile;
  const bool coop = sparse_path == Conv3dPath::kCoopMatrix || sparse_path == Conv3dPath::kCoopMatrixEmulated;
  const uint64_t rows_per_group = register_tile ? uint64_t{NN_SPARSE_ROWS} * NN_SPARSE_GROUP
                                  : coop        ? NN_CONV_COOP_BM
                                                : NN_CONV_TILED_BM;
  const uint32_t co_per_group = register_tile ? NN_CONV_CO_TILE : coop ? NN_CONV_COOP_BN : NN_CONV_TILED_BN;
  const uint32_t group_size = register_tile ? NN_SPARSE_GROUP : coop ? NN_CONV_COOP_GROUP : NN_CONV_TILED_GROUP;
  shader::SparseConvParams pc{};
  pc.rows = s.rows;
  pc.co_vec4s = static_cast<uint32_t>(co_vec4s);
  pc.has_bias = bias ? 1u : 0u;
  const gpu::BufferBinding bb = bias ? bias->binding(0, uint64_t{s.out_channels} * 4) : gpu::null_binding();
  // Input channels per dispatch: lavapipe stops an invocation after 65,535 loop iterations; the register
  // tile makes about 27 * (ci_count + 1), the emulated fragments ~1,100 per K step of 32 (27 / 32 steps
  // per channel).
  const uint64_t kMaxChannelsPerDispatch = sparse_path == Conv3dPath::kCoopMatrixEmulated ? 48 : 2048;
  const uint64_t usable = window_elements(ctx_, max_binding_bytes_);
  uint64_t ci_window = std::min(usable / N, kMaxChannelsPerDispatch);
  // Weights over one binding: windows of whole input channels (27 taps x all output columns each),
  // a multiple of the channels whose rows meet the binding-offset alignment; the input windows follow.
  const uint64_t w_row = w_bytes / s.in_channels;  // one input channel: 27 taps x all output columns
  const uint64_t w_limit = ctx_.info().max_storage_buffer_range;
  const bool w_windows = w_bytes > w_limit;
  if (w_windows) {
    const uint64_t unit = gpu::aligned_element_unit(ctx_.info(), w_row);
    const uint64_t w_channels = w_limit / w_row / unit * unit;
    if (w_channels == 0)
      throw std::invalid_argument("sparse conv: the packed weights of one input channel (" + std::to_string(w_row * unit) +
                                  " bytes for " + std::to_string(s.out_channels) +
                                  " output channels) exceed one storage binding; use fewer output channels");
    // Input windows start where weight windows may: at multiples of `unit` channels.
    ci_window = std::min(ci_window, w_channels) / unit * unit;
  }
  // Output windows of 4 channels at a time (the kernel stores only co_count channels of its tile), so the
  // largest grid one binding allows has 4 output channel planes in it: 8.4 M rows on lavapipe, a whole
  // 256 x 256 x 128 chunk. fp16 weights come in vectors of 8 channels: a window starting at 4 mod 8
  // computes from the vector's start and stores from its co_lead = 4.
  constexpr uint64_t kCoStep = 4;
  const uint64_t co_window = usable / N / kCoStep * kCoStep;
  if (ci_window == 0 || co_window == 0)
    throw std::invalid_argument("sparse conv: " + std::to_string(kCoStep) + " channels of " + std::to_string(N) +
                                " rows exceed one storage binding (at most " + std::to_string(usable / kCoStep) +
                                " rows on this device); use fewer voxels per chunk");
  // Row windows when the kernel map exceeds one binding (they write disjoint rows of y: no barrier
  // between them), then output and input channel windows as Conv3d.
  const uint64_t row_window = kmap_window_rows(ctx_);
  for (uint64_t r0 = 0; r0 < N; r0 += row_window) {
    pc.row_begin = static_cast<uint32_t>(r0);
    pc.row_count = static_cast<uint32_t>(std::min<uint64_t>(row_window, N - r0));
    pc.row_tiles = static_cast<uint32_t>(gpu::div_up(pc.row_count, rows_per_group));
    const gpu::BufferBinding kb = kmap.binding(r0 * NN_SPARSE_TAPS * 4, uint64_t{pc.row_count} * NN_SPARSE_TAPS * 4);
    for (uint64_t co0 = 0; co0 < s.out_channels; co0 += co_window) {
      pc.co_lead = s.f16_weights ? static_cast<uint32_t>(co0 % 8) : 0u;
      pc.co_begin = static_cast<uint32_t>(co0) - pc.co_lead;
      pc.co_count = static_cast<uint32_t>(std::min<uint64_t>(co_window, s.out_channels - co0));
      pc.co_blocks = static_cast<uint32_t>(gpu::div_up(pc.co_lead + pc.co_count, co_per_group));
      const ElementWindow yw = element_window(ctx_, y, co0 * N, uint64_t{pc.co_count} * N);
      pc.y_offset = yw.offset;
      for (uint64_t ci0 = 0; ci0 < s.in_channels; ci0 += ci_window) {
        pc.ci_begin = static_cast<uint32_t>(ci0);
        pc.ci_count = static_cast<uint32_t>(std::min<uint64_t>(ci_window, s.in_channels - ci0));
        pc.accumulate = ci0 > 0 ? 1u : 0u;
        pc.silu = s.silu && ci0 + pc.ci_count >= s.in_channels ? 1u : 0u;  // on the last input window
        if (ci0 > 0) cmd.barrier(gpu::deps::kComputeToCompute);  // later input windows read-modify-write y
        const ElementWindow xw = texel_window(ctx_, x, ci0 * N, uint64_t{pc.ci_count} * N, x_element);
        pc.x_offset = xw.offset;
        pc.w_ci_base = w_windows ? pc.ci_begin : 0u;
        const gpu::BufferBinding wb = w_windows ? w.binding(ci0 * w_row, uint64_t{pc.ci_count} * w_row) : w.binding(0, w_bytes);
        const uint64_t groups = uint64_t{pc.row_tiles} * pc.co_blocks;
        cmd.dispatch(program, gpu::Threads{groups * group_size}, pc, {xw.binding, kb, wb, bb, yw.binding});
      }
    }
  }
}

}  // namespace icube::kernels::nn
