// Building sparse voxel grids on the GPU (shaders/nn/sparse_keep,
// sparse_children, sparse_permute, sparse_gather_rows, sparse_coarse_keys,
// sparse_segments, sparse_coarse_rows, sparse_max_pool, sparse_lookup): the
// encoder's max pooling onto the coarsened grid, hash lookups, the structure
// decision of a VAE head (keep where logit0 > logit1), subdivision of the kept
// voxels into their f_x * f_y * f_z children (coordinates ijk * f + o, sorted
// into brick order by the 64-bit radix sort, features copied from the parent)
// and row gathers. Coordinates stay within +-2^20 (the brick-order key's
// range); sparse tensors as sparse_conv.h (ijk [N][3], features [C][N]).
// The record_* steps leave the barriers to the caller; subdivide() runs the
// whole sequence in two submissions (the kept count is read back to size the
// children) with its barriers inside.
// CPU references: nn::cpu::subdivide, max_pool, find_rows (kernels/nn/sparse_cpu.h).
// Tests: tests/nn/test_sparse_grid.cpp.
#pragma once

#include "kernels/fill.h"
#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/prefix_scan.h"
#include "kernels/radix_sort.h"

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

  // The coarsened grid (max pooling's, floor(ijk / factor), brick order) and the sorted fine rows each
  // coarse row pools: fine rows perm[begin[q] .. begin[q + 1]). Two submissions (the coarse count is read back).
  struct Coarse {
    uint32_t rows = 0, fine_rows = 0;
    gpu::Buffer ijk;    // int32 [rows][3]
    gpu::Buffer perm;   // uint32 [fine_rows]: fine rows sorted by coarse voxel
    gpu::Buffer begin;  // uint32 [rows]
  };
  Coarse coarsen(const gpu::Buffer& ijk, uint32_t rows, const std::array<int32_t, 3>& factor);
  // y [channels][coarse.rows] = max pooling of x [channels][coarse.fine_rows].
  void record_max_pool(gpu::CommandList& cmd, const Coarse& coarse, const gpu::Buffer& x, uint32_t channels,
                       const gpu::Buffer& y);
  // rows[i] = the row of query_ijk[i] in the grid hashed into `table` (SparseKernelMap::record_insert), or -1.
  void record_lookup(gpu::CommandList& cmd, uint32_t grid_rows, const gpu::Buffer& ijk, const gpu::Buffer& table,
                     uint32_t table_size, uint32_t queries, const gpu::Buffer& query_ijk, const gpu::Buffer& rows);

 private:
  gpu::Context& ctx_;
  gpu::Program& keep_;
  gpu::Program& children_;
  gpu::Program& permute_;
  gpu::Program& gather_;
  gpu::Program& coarse_keys_;
  gpu::Program& segments_;
  gpu::Program& coarse_rows_;
  gpu::Program& max_pool_;
  gpu::Program& lookup_;
  PrefixScan scan_;
  RadixSort sort_;
  Iota iota_;
};

}  // namespace icube::kernels::nn
