// Building sparse voxel grids on the GPU (shaders/nn/sparse_keep,
// sparse_children, sparse_permute, sparse_gather_rows): the structure
// decision of a VAE head (keep where logit0 > logit1), subdivision of the kept
// voxels into their f_x * f_y * f_z children (coordinates ijk * f + o, sorted
// into brick order by the 64-bit radix sort, features copied from the parent)
// and row gathers. Coordinates stay within +-2^20 (the brick-order key's
// range); sparse tensors as sparse_conv.h (ijk [N][3], features [C][N]).
// The record_* steps leave the barriers to the caller; subdivide() runs the
// whole sequence in two submissions (the kept count is read back to size the
// children) with its barriers inside.
// CPU reference: nn::cpu::subdivide (kernels/nn/sparse_cpu.h).
// Tests: tests/nn/test_sparse_grid_gpu.cpp.
#pragma once

#include "fill.h"
#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "prefix_scan.h"
#include "radix_sort.h"

#include <array>
#include <cstdint>

namespace icube::kernels::nn {

class SparseGridOps {
 public:
  explicit SparseGridOps(gpu::Context& ctx);

  void record_keep(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& logits, const gpu::Buffer& keep);
  // Children of the kept rows (incl = inclusive scan of keep); keys: uint64 per child.
  void record_children(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& ijk, const gpu::Buffer& keep,
                       const gpu::Buffer& incl, const std::array<int32_t, 3>& factor, const gpu::Buffer& child_ijk,
                       const gpu::Buffer& parent, const gpu::Buffer& keys);
  void record_permute(gpu::CommandList& cmd, uint32_t rows, const gpu::Buffer& perm, const gpu::Buffer& in_ijk,
                      const gpu::Buffer& in_parent, const gpu::Buffer& out_ijk, const gpu::Buffer& out_parent);
  // y [channels][out_rows] = x [channels][in_rows] at `rows` (int32, -1 = zero); channel windows when a
  // tensor exceeds one binding.
  void record_gather_rows(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t in_rows, uint32_t channels,
                          const gpu::Buffer& rows, uint32_t out_rows, const gpu::Buffer& y);

  struct Children {
    uint32_t rows = 0;
    gpu::Buffer ijk;     // int32 [rows][3], brick order
    gpu::Buffer parent;  // int32 parent row per child
  };
  // The children of the rows whose structure logits ([2][rows], channel-major) say keep.
  Children subdivide(const gpu::Buffer& ijk, uint32_t rows, const gpu::Buffer& logits,
                     const std::array<int32_t, 3>& factor);

 private:
  gpu::Context& ctx_;
  gpu::Program& keep_;
  gpu::Program& children_;
  gpu::Program& permute_;
  gpu::Program& gather_;
  PrefixScan scan_;
  RadixSort sort_;
  Iota iota_;
};

}  // namespace icube::kernels::nn
