// Sparse voxel convolution on the GPU: the neighbour ("kernel") map of a
// submanifold 3^3 convolution, built from a hash of the grid's coordinates
// (shaders/nn/sparse_hash_insert.comp, nn/sparse_kernel_map.comp), and the
// convolution itself: an output-stationary gather over it on lavapipe
// (nn/sparse_conv.comp), a gathered implicit GEMM on GPUs (sparse_conv_tiled,
// sparse_conv_coopmat), fp32 or fp16 weights. GPU sparse tensors: coordinates int32 [N][3] in brick
// order, features channel-major [C][N] (see shaders/shared/nn_params.h), so
// GroupNorm, SiLU, add and 1x1 convolutions are the dense kernels on a
// [1, C, N, 1, 1] view (a 1x1 sparse convolution is Conv3d with kernel 1 over
// 1 x 1 x N voxels).
//
// A kernel map depends only on the grid: build it once per grid and reuse it
// for every 3^3 convolution there (the VAE builds one per level). Kernel maps
// beyond one storage binding (N * 27 * 4 bytes: 1.24 M rows on lavapipe's
// 128 MiB) are written and read in row windows, features beyond one binding in
// channel windows (as Conv3d), packed weights beyond one binding in windows of
// whole input channels.
// CPU references: nn::cpu::kernel_map / nn::cpu::conv3d (kernels/nn/sparse_cpu.h).
// Tests: tests/nn/test_sparse_conv.cpp.
#pragma once

#include "kernels/nn/conv3d.h"

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstdint>
#include <optional>

namespace icube::kernels::nn {

class SparseKernelMap {
 public:
  explicit SparseKernelMap(gpu::Context& ctx);
  // Hash table slots for `rows` coordinates: a power of two >= 2 * rows (>= 64).
  static uint32_t table_size(uint64_t rows);
  // The three steps, in order, each to be separated by a compute-to-compute barrier by the caller:
  // clear the table (zeros), insert every row, then write kmap [rows][27] (int32, -1 = missing).
  void record_clear(gpu::CommandList& cmd, const gpu::Buffer& table, uint32_t table_size);
  void record_insert(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& ijk, const gpu::Buffer& table,
                     uint32_t table_size);
  void record_map(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& ijk, const gpu::Buffer& table,
                  uint32_t table_size, const gpu::Buffer& kmap);

 private:
  gpu::Context& ctx_;
  gpu::Program& insert_;
  gpu::Program& map_;
};

struct SparseConvShape {
  uint32_t rows = 0, in_channels = 1, out_channels = 1;
  bool silu = false;         // y = silu(conv + bias), fused into the store
  bool f16_weights = false;  // packed weights as fp16 (pack_conv3d_weights_f16; nn/sparse_conv*_f16w.comp)
  bool f16_input = false;    // x stored as fp16 (an R16_SFLOAT texel view: every path reads it unchanged)
  uint64_t flops(uint64_t pairs) const { return 2ull * in_channels * out_channels * pairs; }  // pairs: kmap entries >= 0
};

class SparseConv3d {
 public:
  explicit SparseConv3d(gpu::Context& ctx);
  // y [Co][N] = conv(x [Ci][N]) + bias over kmap [N][27]; packed_weights from pack_conv3d_weights (kernel 3) of
  // the grid-order weight, or pack_conv3d_weights_f16 with s.f16_weights; `bias` may be nullptr. The only barriers inside are between input-channel windows.
  void record(gpu::CommandList& cmd, const SparseConvShape& s, const gpu::Buffer& x, const gpu::Buffer& kmap,
              const gpu::Buffer& packed_weights, const gpu::Buffer* bias, const gpu::Buffer& y);
  // Tests: the feature windows as if one binding held `bytes` (0: the device's); kernel-map and weight
  // windows follow the context's limit (ContextOptions::max_storage_binding).
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }
  // The kernel, as Conv3d's (default_conv3d_path): the register tile (nn/sparse_conv.comp) in lavapipe's
  // kernel family; in the GPUs' (kernels/nn/kernel_family.h) the gathered implicit GEMM on tensor cores
  // (nn/sparse_conv_coopmat.comp) with fp16 weights where the device has cooperative matrices, else on
  // the shared-memory tile (nn/sparse_conv_tiled.comp). Tests and benchmarks may force any path
  // (nullopt: that default); a path the device cannot run is refused when recorded.
  void force_path(std::optional<Conv3dPath> path) { forced_path_ = path; }
  Conv3dPath path(bool f16_weights) const;
  static const char* shader_name(Conv3dPath path, bool f16_weights);  // "nn/sparse_conv_tiled_f16w", ...

 private:
  gpu::Context& ctx_;
  uint64_t max_binding_bytes_ = 0;
  std::optional<Conv3dPath> forced_path_;
};

}  // namespace icube::kernels::nn
