// Random sparse grids for the sparse-layer tests (tests/nn/test_sparse_*.cpp).
#pragma once

#include "kernels/nn/sparse_cpu.h"

#include <algorithm>
#include <random>
#include <set>

namespace icube::test {

// `count` distinct random voxels of the box [lo, lo + dims) (at most the box), in brick order.
inline nn::SparseGrid random_sparse_grid(std::mt19937& rng, const nn::Ijk& lo, const nn::Ijk& dims, size_t count) {
  std::set<nn::Ijk> s;
  std::uniform_int_distribution<int32_t> di(0, dims[0] - 1), dj(0, dims[1] - 1), dk(0, dims[2] - 1);
  const size_t cap = static_cast<size_t>(int64_t{dims[0]} * dims[1] * dims[2]);
  while (s.size() < std::min(count, cap)) s.insert({lo[0] + di(rng), lo[1] + dj(rng), lo[2] + dk(rng)});
  nn::SparseGrid g;
  g.ijk.assign(s.begin(), s.end());
  nn::sort_brick_order(g);
  return g;
}

inline nn::SparseGrid random_sparse_grid(uint32_t seed, const nn::Ijk& lo, const nn::Ijk& dims, size_t count) {
  std::mt19937 rng(seed);
  return random_sparse_grid(rng, lo, dims, count);
}

}  // namespace icube::test
