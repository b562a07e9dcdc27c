// Plain-loop CPU references of the sparse layers; see sparse_cpu.h.
#include "kernels/nn/sparse_cpu.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace icube::nn {

namespace {

struct IjkHash {
  size_t operator()(const Ijk& c) const {
    uint64_t h = static_cast<uint32_t>(c[0]);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(c[1]);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(c[2]);
    return static_cast<size_t>(h ^ (h >> 29));
  }
};

using RowMap = std::unordered_map<Ijk, int32_t, IjkHash>;

double f64(float v) { return static_cast<double>(v); }

RowMap row_map(const SparseGrid& grid) {
  RowMap m;
  m.reserve(grid.ijk.size() * 2);
  for (size_t r = 0; r < grid.ijk.size(); ++r)
    if (!m.emplace(grid.ijk[r], static_cast<int32_t>(r)).second)
      throw std::invalid_argument("sparse grid: voxel (" + std::to_string(grid.ijk[r][0]) + ", " +
                                  std::to_string(grid.ijk[r][1]) + ", " + std::to_string(grid.ijk[r][2]) +
                                  ") appears twice");
  return m;
}

void require_rows(const SparseTensor& x, const char* op) {
  if (static_cast<int64_t>(x.data.size()) != x.rows() * x.channels)
    throw std::invalid_argument(std::string(op) + ": " + std::to_string(x.data.size()) + " values for " +
                                std::to_string(x.rows()) + " rows x " + std::to_string(x.channels) + " channels");
}

SparseTensor with_grid(const SparseGrid& grid, int64_t channels) {
  SparseTensor y;
  y.grid = grid;
  y.channels = channels;
  y.data.assign(static_cast<size_t>(grid.size() * channels), 0.0f);
  return y;
}

}  // namespace

bool brick_order_less(const Ijk& a, const Ijk& b) {
  for (int d = 0; d < 3; ++d) {
    const int32_t ba = floor_div(a[d], 8), bb = floor_div(b[d], 8);
    if (ba != bb) return ba < bb;
  }
  return a < b;
}

std::vector<int64_t> sort_brick_order(SparseGrid& grid) {
  std::vector<int64_t> perm(grid.ijk.size());
  std::iota(perm.begin(), perm.end(), 0);
  std::sort(perm.begin(), perm.end(), [&](int64_t a, int64_t b) { return brick_order_less(grid.ijk[a], grid.ijk[b]); });
  std::vector<Ijk> sorted(grid.ijk.size());
  for (size_t r = 0; r < perm.size(); ++r) sorted[r] = grid.ijk[perm[r]];
  grid.ijk = std::move(sorted);
  return perm;
}

SparseGrid dense_box_grid(const Ijk& lo, const Ijk& dims, const std::array<double, 3>& voxel_size,
                          const std::array<double, 3>& origin) {
  SparseGrid g;
  g.voxel_size = voxel_size;
  g.origin = origin;
  g.ijk.reserve(static_cast<size_t>(int64_t{dims[0]} * dims[1] * dims[2]));
  for (int32_t i = 0; i < dims[0]; ++i)
    for (int32_t j = 0; j < dims[1]; ++j)
      for (int32_t k = 0; k < dims[2]; ++k) g.ijk.push_back({lo[0] + i, lo[1] + j, lo[2] + k});
  sort_brick_order(g);
  return g;
}

namespace cpu {

std::vector<int32_t> find_rows(const SparseGrid& grid, const std::vector<Ijk>& query) {
  const RowMap m = row_map(grid);
  std::vector<int32_t> rows(query.size(), -1);
  for (size_t q = 0; q < query.size(); ++q) {
    const auto it = m.find(query[q]);
    if (it != m.end()) rows[q] = it->second;
  }
  return rows;
}

std::vector<int32_t> kernel_map(const SparseGrid& grid, int kernel) {
  if (kernel < 1 || kernel % 2 == 0) throw std::invalid_argument("kernel_map: kernel " + std::to_string(kernel) + " is not odd");
  const RowMap m = row_map(grid);
  const int taps = kernel * kernel * kernel, h = kernel / 2;
  std::vector<int32_t> map(static_cast<size_t>(grid.size() * taps), -1);
  for (size_t r = 0; r < grid.ijk.size(); ++r)
    for (int a = 0; a < kernel; ++a)
      for (int b = 0; b < kernel; ++b)
        for (int c = 0; c < kernel; ++c) {
          const Ijk q{grid.ijk[r][0] + a - h, grid.ijk[r][1] + b - h, grid.ijk[r][2] + c - h};
          const auto it = m.find(q);
          if (it != m.end()) map[r * taps + static_cast<size_t>((a * kernel + b) * kernel + c)] = it->second;
        }
  return map;
}

SparseTensor conv3d(const SparseTensor& x, const CpuTensor& w, const CpuTensor* bias) {
  require_rows(x, "sparse conv3d");
  if (w.rank() != 5 || w.dim(1) != x.channels || w.dim(2) != w.dim(3) || w.dim(3) != w.dim(4))
    throw std::invalid_argument("sparse conv3d: weight " + w.shape_text() + " for " + std::to_string(x.channels) +
                                " input channels");
  const int64_t co = w.dim(0), ci = x.channels;
  const int k = static_cast<int>(w.dim(2)), taps = k * k * k;
  if (bias && bias->numel() != co) throw std::invalid_argument("sparse conv3d: bias " + bias->shape_text());
  const std::vector<int32_t> map = kernel_map(x.grid, k);
  SparseTensor y = with_grid(x.grid, co);
  std::vector<double> acc(static_cast<size_t>(co));
  for (int64_t r = 0; r < x.rows(); ++r) {
    for (int64_t o = 0; o < co; ++o) acc[o] = bias ? f64(bias->data[o]) : 0.0;
    for (int t = 0; t < taps; ++t) {
      const int32_t src = map[static_cast<size_t>(r * taps + t)];
      if (src < 0) continue;
      const float* xr = x.row(src);
      for (int64_t o = 0; o < co; ++o) {
        const float* wr = w.data.data() + (o * ci) * taps + t;
        double s = 0.0;
        for (int64_t i = 0; i < ci; ++i) s += f64(wr[i * taps]) * f64(xr[i]);
        acc[o] += s;
      }
    }
    for (int64_t o = 0; o < co; ++o) y.row(r)[o] = static_cast<float>(acc[o]);
  }
  return y;
}

SparseTensor linear(const SparseTensor& x, const CpuTensor& w, const CpuTensor* bias) {
  require_rows(x, "sparse linear");
  const bool ok = (w.rank() == 2 || (w.rank() == 5 && w.dim(2) == 1 && w.dim(3) == 1 && w.dim(4) == 1)) &&
                  w.dim(1) == x.channels;
  if (!ok)
    throw std::invalid_argument("sparse linear: weight " + w.shape_text() + " for " + std::to_string(x.channels) +
                                " input channels");
  const int64_t co = w.dim(0), ci = x.channels;
  if (bias && bias->numel() != co) throw std::invalid_argument("sparse linear: bias " + bias->shape_text());
  SparseTensor y = with_grid(x.grid, co);
  for (int64_t r = 0; r < x.rows(); ++r)
    for (int64_t o = 0; o < co; ++o) {
      double s = bias ? f64(bias->data[o]) : 0.0;
      for (int64_t i = 0; i < ci; ++i) s += f64(w.data[o * ci + i]) * f64(x.row(r)[i]);
      y.row(r)[o] = static_cast<float>(s);
    }
  return y;
}

SparseTensor group_norm(const SparseTensor& x, int groups, const CpuTensor& weight, const CpuTensor& bias, double eps) {
  require_rows(x, "sparse group_norm");
  const int64_t c = x.channels;
  if (groups < 1 || c % groups != 0)
    throw std::invalid_argument("sparse group_norm: " + std::to_string(c) + " channels in " + std::to_string(groups) + " groups");
  if (weight.numel() != c || bias.numel() != c) throw std::invalid_argument("sparse group_norm: affine parameters");
  SparseTensor y = x;
  const int64_t cg = c / groups, n = x.rows();
  if (n == 0) return y;
  for (int g = 0; g < groups; ++g) {
    double sum = 0.0;
    for (int64_t r = 0; r < n; ++r)
      for (int64_t q = 0; q < cg; ++q) sum += f64(x.row(r)[g * cg + q]);
    const double mean = sum / static_cast<double>(n * cg);
    double var = 0.0;
    for (int64_t r = 0; r < n; ++r)
      for (int64_t q = 0; q < cg; ++q) {
        const double d = f64(x.row(r)[g * cg + q]) - mean;
        var += d * d;
      }
    const double inv = 1.0 / std::sqrt(var / static_cast<double>(n * cg) + eps);
    for (int64_t r = 0; r < n; ++r)
      for (int64_t q = 0; q < cg; ++q) {
        const int64_t ch = g * cg + q;
        y.row(r)[ch] = static_cast<float>((f64(x.row(r)[ch]) - mean) * inv * f64(weight.data[ch]) + f64(bias.data[ch]));
      }
  }
  return y;
}

SparseTensor silu(SparseTensor x) {
  for (float& v : x.data) v = static_cast<float>(double{v} / (1.0 + std::exp(-double{v})));
  return x;
}

SparseTensor add(SparseTensor a, const SparseTensor& b) {
  if (a.data.size() != b.data.size() || a.channels != b.channels)
    throw std::invalid_argument("sparse add: " + std::to_string(a.rows()) + "x" + std::to_string(a.channels) + " + " +
                                std::to_string(b.rows()) + "x" + std::to_string(b.channels));
  for (size_t i = 0; i < a.data.size(); ++i) a.data[i] += b.data[i];
  return a;
}

SparseTensor max_pool(const SparseTensor& x, const Ijk& factor) {
  require_rows(x, "sparse max_pool");
  for (int d = 0; d < 3; ++d)
    if (factor[d] < 1) throw std::invalid_argument("sparse max_pool: factor " + std::to_string(factor[d]));
  SparseGrid coarse;
  for (int d = 0; d < 3; ++d) {
    coarse.voxel_size[d] = x.grid.voxel_size[d] * factor[d];
    coarse.origin[d] = x.grid.origin[d] + (factor[d] - 1) * x.grid.voxel_size[d] / 2.0;
  }
  RowMap seen;
  for (const Ijk& c : x.grid.ijk) {
    const Ijk p{floor_div(c[0], factor[0]), floor_div(c[1], factor[1]), floor_div(c[2], factor[2])};
    if (seen.emplace(p, 0).second) coarse.ijk.push_back(p);
  }
  sort_brick_order(coarse);
  const RowMap rows = row_map(coarse);
  SparseTensor y = with_grid(coarse, x.channels);
  std::fill(y.data.begin(), y.data.end(), -INFINITY);
  for (int64_t r = 0; r < x.rows(); ++r) {
    const Ijk& c = x.grid.ijk[static_cast<size_t>(r)];
    const int32_t dst = rows.at({floor_div(c[0], factor[0]), floor_div(c[1], factor[1]), floor_div(c[2], factor[2])});
    for (int64_t ch = 0; ch < x.channels; ++ch) y.row(dst)[ch] = std::max(y.row(dst)[ch], x.row(r)[ch]);
  }
  return y;
}

SparseTensor subdivide(const SparseTensor& x, const std::vector<uint8_t>& keep, const Ijk& factor) {
  require_rows(x, "sparse subdivide");
  if (static_cast<int64_t>(keep.size()) != x.rows())
    throw std::invalid_argument("sparse subdivide: " + std::to_string(keep.size()) + " decisions for " +
                                std::to_string(x.rows()) + " rows");
  SparseGrid fine;
  for (int d = 0; d < 3; ++d) {
    if (factor[d] < 1) throw std::invalid_argument("sparse subdivide: factor " + std::to_string(factor[d]));
    fine.voxel_size[d] = x.grid.voxel_size[d] / factor[d];
    fine.origin[d] = x.grid.origin[d] - (factor[d] - 1) * fine.voxel_size[d] / 2.0;
  }
  std::vector<int64_t> parent;
  for (int64_t r = 0; r < x.rows(); ++r) {
    if (!keep[static_cast<size_t>(r)]) continue;
    const Ijk& c = x.grid.ijk[static_cast<size_t>(r)];
    for (int32_t a = 0; a < factor[0]; ++a)
      for (int32_t b = 0; b < factor[1]; ++b)
        for (int32_t e = 0; e < factor[2]; ++e) {
          fine.ijk.push_back({c[0] * factor[0] + a, c[1] * factor[1] + b, c[2] * factor[2] + e});
          parent.push_back(r);
        }
  }
  const std::vector<int64_t> perm = sort_brick_order(fine);
  SparseTensor y = with_grid(fine, x.channels);
  for (size_t r = 0; r < perm.size(); ++r)
    std::copy_n(x.row(parent[static_cast<size_t>(perm[r])]), x.channels, y.row(static_cast<int64_t>(r)));
  return y;
}

CpuTensor to_dense(const SparseTensor& x, const Ijk& lo, const Ijk& dims) {
  require_rows(x, "sparse to_dense");
  CpuTensor d({1, x.channels, dims[0], dims[1], dims[2]});
  const int64_t S = int64_t{dims[0]} * dims[1] * dims[2];
  for (int64_t r = 0; r < x.rows(); ++r) {
    const Ijk& c = x.grid.ijk[static_cast<size_t>(r)];
    const int64_t i = c[0] - lo[0], j = c[1] - lo[1], k = c[2] - lo[2];
    if (i < 0 || j < 0 || k < 0 || i >= dims[0] || j >= dims[1] || k >= dims[2]) continue;
    const int64_t v = (i * dims[1] + j) * dims[2] + k;
    for (int64_t ch = 0; ch < x.channels; ++ch) d.data[static_cast<size_t>(ch * S + v)] = x.row(r)[ch];
  }
  return d;
}

SparseTensor from_dense(const CpuTensor& dense, const Ijk& lo, const SparseGrid& grid) {
  if (dense.rank() != 5 || dense.dim(0) != 1)
    throw std::invalid_argument("sparse from_dense: tensor " + dense.shape_text() + " is not [1, C, X, Y, Z]");
  const int64_t C = dense.dim(1), X = dense.dim(2), Y = dense.dim(3), Z = dense.dim(4);
  SparseTensor y = with_grid(grid, C);
  for (int64_t r = 0; r < y.rows(); ++r) {
    const Ijk& c = grid.ijk[static_cast<size_t>(r)];
    const int64_t i = c[0] - lo[0], j = c[1] - lo[1], k = c[2] - lo[2];
    if (i < 0 || j < 0 || k < 0 || i >= X || j >= Y || k >= Z) continue;
    for (int64_t ch = 0; ch < C; ++ch) y.row(r)[ch] = dense.data[static_cast<size_t>(((ch * X + i) * Y + j) * Z + k)];
  }
  return y;
}

}  // namespace cpu
}  // namespace icube::nn
