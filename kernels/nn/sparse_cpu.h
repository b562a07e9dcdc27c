// Sparse voxel tensors and plain-loop CPU references of the sparse network
// layers (the oracles of the GPU kernels, and the whole-network reference of
// engine/nn/vae_reference.h). Conventions are fVDB's, as InfiniCube's
// networks use them (conventions §2, §8.1):
//   grid        active voxel coordinates ijk (int32), world = ijk * voxel_size + origin (voxel centres);
//               a tensor's feature rows follow its grid's rows
//   conv3d      submanifold (output sites = input sites): a cross-correlation with padding k/2 over the
//               zero-filled grid, read at the sites. The weight here is in GRID order [Co, Ci, ki, kj, kk]
//               (tap (a, b, c) reads ijk + (a, b, c) - k/2); fVDB 0.2.0 checkpoints store the kernel axes
//               reversed and are converted once, on load (engine/nn/vae_weights.h)
//   linear      a 1x1x1 convolution: y = x W^T + b per row, W [Co, Ci]
//   group_norm  torch GroupNorm over the active voxels: biased variance per group, eps inside the sqrt
//   max_pool    coarse ijk = floor(ijk / f); each coarse voxel is the maximum of its active children
//               (fVDB: init -inf, inactive children skipped); coarse voxel size vs * f, origin
//               origin + (f - 1) * vs / 2
//   subdivide   keep the rows whose mask is set, each becomes its children ijk * f + o, o in [0, f),
//               features copied; fine voxel size vs / f, origin origin - (f - 1) * vs_fine / 2
// Row order: grids built here are in brick order (8^3 bricks lexicographic in
// (i, j, k), then voxels lexicographic inside a brick), as the engine's world
// grid stores them. Sums accumulate in double. Tests: tests/nn/test_sparse_cpu.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"

#include <array>
#include <cstdint>
#include <vector>

namespace icube::nn {

using Ijk = std::array<int32_t, 3>;

struct SparseGrid {
  std::vector<Ijk> ijk;
  std::array<double, 3> voxel_size{1.0, 1.0, 1.0};
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  int64_t size() const { return static_cast<int64_t>(ijk.size()); }
};

// Features [N, C], row-major, rows = grid rows.
struct SparseTensor {
  SparseGrid grid;
  int64_t channels = 0;
  std::vector<float> data;
  int64_t rows() const { return grid.size(); }
  float* row(int64_t r) { return data.data() + r * channels; }
  const float* row(int64_t r) const { return data.data() + r * channels; }
};

// floor(a / b) for b > 0.
inline int32_t floor_div(int32_t a, int32_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// True when a precedes b in brick order.
bool brick_order_less(const Ijk& a, const Ijk& b);
// The rows of `grid` sorted into brick order; returns the permutation (new row r = old row perm[r]).
std::vector<int64_t> sort_brick_order(SparseGrid& grid);

// Every voxel of the box [lo, lo + dims) in brick order.
SparseGrid dense_box_grid(const Ijk& lo, const Ijk& dims, const std::array<double, 3>& voxel_size,
                          const std::array<double, 3>& origin);

namespace cpu {

// Row of every coordinate of `query` in `grid`, or -1 (a hash map of the grid's coordinates).
std::vector<int32_t> find_rows(const SparseGrid& grid, const std::vector<Ijk>& query);

// Neighbour map of a submanifold k^3 convolution: [N, k^3], entry [r][(a * k + b) * k + c] = the row
// of ijk[r] + (a, b, c) - k/2, or -1.
std::vector<int32_t> kernel_map(const SparseGrid& grid, int kernel);

// Submanifold convolution; w [Co, Ci, k, k, k] in grid order (see above), bias [Co] or null.
SparseTensor conv3d(const SparseTensor& x, const CpuTensor& w, const CpuTensor* bias);
// 1x1x1 convolution; w [Co, Ci] (or [Co, Ci, 1, 1, 1]), bias [Co] or null.
SparseTensor linear(const SparseTensor& x, const CpuTensor& w, const CpuTensor* bias);
SparseTensor group_norm(const SparseTensor& x, int groups, const CpuTensor& weight, const CpuTensor& bias,
                        double eps = 1e-5);
SparseTensor silu(SparseTensor x);
SparseTensor add(SparseTensor a, const SparseTensor& b);  // same grid rows and channels

// Max pooling by `factor` per axis onto the coarsened grid (brick order).
SparseTensor max_pool(const SparseTensor& x, const Ijk& factor);
// Rows with keep[r] != 0, each split into its factor[0] * factor[1] * factor[2] children (brick order).
SparseTensor subdivide(const SparseTensor& x, const std::vector<uint8_t>& keep, const Ijk& factor);

// The features of `x` inside the box [lo, lo + dims) as a dense [1, C, dims...] tensor (zeros elsewhere),
// and back: the dense tensor's values at the rows of `grid`.
CpuTensor to_dense(const SparseTensor& x, const Ijk& lo, const Ijk& dims);
SparseTensor from_dense(const CpuTensor& dense, const Ijk& lo, const SparseGrid& grid);

}  // namespace cpu
}  // namespace icube::nn
