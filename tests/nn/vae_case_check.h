// The official vae_small reference decode (../shared/data/models/vae_small):
// loading its latent as a sparse tensor, and checking a decode against it —
// the same voxel set at every level (as sets keyed by ijk) and max |logit −
// ref| / std(ref) <= 1e-4 for the structure and semantic logits. Shared by the
// CPU reference and GPU VAE tests.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/sparse_cpu.h"
#include "nn/vae_reference.h"
#include "world/npy.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <map>
#include <string>

namespace icube::test {

// The case's latent [1, C, X, Y, Z] on its dense box (latent_ijk_min from config.json: the box centred on 0).
inline nn::SparseTensor vae_small_latent(const std::string& dir) {
  const world::NpyArray a = world::read_npy(dir + "small.latent.npy");
  const nn::CpuTensor dense(std::vector<int64_t>(a.shape.begin(), a.shape.end()), a.values<float>());
  const nn::Ijk dims{static_cast<int32_t>(dense.dim(2)), static_cast<int32_t>(dense.dim(3)), static_cast<int32_t>(dense.dim(4))};
  const nn::Ijk lo{-dims[0] / 2, -dims[1] / 2, -dims[2] / 2};
  const nn::SparseGrid grid = nn::dense_box_grid(lo, dims, {0.8, 0.8, 0.4}, {0.4, 0.4, 0.2});
  return nn::cpu::from_dense(dense, lo, grid);
}

struct VaeCaseResult {
  double worst_struct = 0.0, semantic = 0.0;
  size_t voxels = 0;
};

// Rows of `ref_ijk` [N, 3] in `grid`; every reference voxel must be there and the counts equal.
inline std::vector<int32_t> match_rows(const nn::SparseGrid& grid, const world::NpyArray& ref_ijk, const std::string& what) {
  const std::vector<int32_t> v = ref_ijk.values<int32_t>();
  std::vector<nn::Ijk> q(v.size() / 3);
  for (size_t r = 0; r < q.size(); ++r) q[r] = {v[3 * r], v[3 * r + 1], v[3 * r + 2]};
  const std::vector<int32_t> rows = nn::cpu::find_rows(grid, q);
  INFO(what << ": " << grid.size() << " voxels, reference " << q.size());
  CHECK(static_cast<int64_t>(q.size()) == grid.size());
  CHECK(std::count(rows.begin(), rows.end(), -1) == 0);
  return rows;
}

// max |got[rows] - ref| / std(ref) for [N, C] logits.
inline double rows_error(const std::vector<float>& got, int64_t channels, const std::vector<int32_t>& rows,
                         const std::vector<float>& ref) {
  std::vector<float> picked(ref.size(), 0.0f);
  for (size_t r = 0; r < rows.size(); ++r)
    if (rows[r] >= 0)
      std::copy_n(got.begin() + rows[r] * channels, channels, picked.begin() + static_cast<int64_t>(r) * channels);
  return nn::cpu::max_abs_over_std(picked, ref);
}

inline VaeCaseResult check_vae_small_decode(const std::string& dir, const nn::VaeDecoded& d) {
  VaeCaseResult res;
  REQUIRE(d.levels.size() == 3);
  CHECK(d.warning.empty());
  for (int depth = 2; depth >= 0; --depth) {
    const std::string base = dir + "small.struct" + std::to_string(depth);
    const nn::VaeLevel& level = d.levels[static_cast<size_t>(depth)];
    const std::vector<int32_t> rows = match_rows(level.grid, world::read_npy(base + ".ijk.npy"), "struct" + std::to_string(depth));
    const double e = rows_error(level.logits, 2, rows, world::read_npy(base + ".logits.npy").values<float>());
    INFO("struct" << depth << " logits: max |d| / std = " << e);
    CHECK(e <= 1e-4);
    res.worst_struct = std::max(res.worst_struct, e);
  }
  const std::vector<int32_t> rows = match_rows(d.semantic.grid, world::read_npy(dir + "small.ijk.npy"), "output voxels");
  res.semantic = rows_error(d.semantic.data, d.semantic.channels, rows, world::read_npy(dir + "small.semantic.npy").values<float>());
  CHECK(d.semantic.channels == 23);
  CHECK(res.semantic <= 1e-4);
  res.voxels = static_cast<size_t>(d.semantic.rows());
  return res;
}

}  // namespace icube::test
