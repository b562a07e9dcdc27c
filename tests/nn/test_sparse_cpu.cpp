// The sparse layer references (kernels/nn/sparse_cpu.h) against dense
// definitions: submanifold conv = dense conv3d over the zero-filled box read at
// the sites; max pooling, subdivision, GroupNorm over active voxels; brick
// order; grids with negative and far-from-origin coordinates.
#include "kernels/nn/conv3d.h"
#include "kernels/nn/group_norm.h"
#include "kernels/nn/sparse_cpu.h"
#include "sparse_test_util.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>

using namespace icube;
using nn::Ijk;

namespace {

nn::SparseTensor random_features(std::mt19937& rng, const nn::SparseGrid& g, int64_t channels, float scale = 1.0f) {
  std::normal_distribution<float> n(0.0f, scale);
  nn::SparseTensor x;
  x.grid = g;
  x.channels = channels;
  x.data.resize(static_cast<size_t>(g.size() * channels));
  for (float& v : x.data) v = n(rng);
  return x;
}

nn::CpuTensor random_tensor(std::mt19937& rng, std::vector<int64_t> shape) {
  std::normal_distribution<float> n(0.0f, 0.3f);
  nn::CpuTensor t(std::move(shape));
  for (float& v : t.data) v = n(rng);
  return t;
}

// Sparse conv == dense conv3d of the zero-filled box, read at the sites (max |d| <= 1e-5 * max |ref|).
void check_conv_against_dense(std::mt19937& rng, const nn::SparseGrid& g, int64_t ci, int64_t co, int k) {
  const nn::SparseTensor x = random_features(rng, g, ci);
  const nn::CpuTensor w = random_tensor(rng, {co, ci, k, k, k}), b = random_tensor(rng, {co});
  const nn::SparseTensor y = nn::cpu::conv3d(x, w, &b);
  REQUIRE(y.rows() == g.size());
  if (g.size() == 0) return;
  Ijk lo = g.ijk[0], hi = g.ijk[0];
  for (const Ijk& c : g.ijk)
    for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], c[d]), hi[d] = std::max(hi[d], c[d]);
  const Ijk dims{hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1};
  const nn::CpuTensor dense = nn::cpu::conv3d(nn::cpu::to_dense(x, lo, dims), w, &b, 1, k / 2);
  const nn::SparseTensor ref = nn::cpu::from_dense(dense, lo, g);
  double worst = 0.0, peak = 0.0;
  for (size_t i = 0; i < ref.data.size(); ++i) {
    worst = std::max(worst, std::abs(double{y.data[i]} - double{ref.data[i]}));
    peak = std::max(peak, std::abs(double{ref.data[i]}));
  }
  INFO(g.size() << " voxels, " << ci << " -> " << co << ", k " << k << ": max |d| " << worst << " of " << peak);
  CHECK(worst <= 1e-5 * peak + 1e-6);
}

}  // namespace

TEST_CASE("sparse cpu: brick order, dense boxes and row lookup") {
  nn::SparseGrid g;
  g.ijk = {{9, 0, 0}, {-1, 0, 0}, {0, 0, 0}, {7, 7, 7}, {8, 0, 0}, {-8, 0, 0}, {-9, 5, 5}};
  nn::sort_brick_order(g);
  // Bricks (floor(c / 8)): (-2,0,0) < (-1,0,0) < (0,0,0) < (1,0,0); inside a brick lexicographic.
  const std::vector<Ijk> want{{-9, 5, 5}, {-8, 0, 0}, {-1, 0, 0}, {0, 0, 0}, {7, 7, 7}, {8, 0, 0}, {9, 0, 0}};
  CHECK(g.ijk == want);
  CHECK(nn::floor_div(-1, 8) == -1);
  CHECK(nn::floor_div(-8, 8) == -1);
  CHECK(nn::floor_div(-9, 8) == -2);
  CHECK(nn::floor_div(7, 8) == 0);
  const nn::SparseGrid box = nn::dense_box_grid({-3, -2, -1}, {5, 4, 3}, {0.8, 0.8, 0.4}, {0.4, 0.4, 0.2});
  CHECK(box.size() == 60);
  CHECK(std::is_sorted(box.ijk.begin(), box.ijk.end(), nn::brick_order_less));
  const std::vector<int32_t> rows = nn::cpu::find_rows(box, {{-3, -2, -1}, {1, 1, 1}, {2, 0, 0}, {0, 0, 2}});
  CHECK(rows[0] >= 0);
  CHECK(rows[1] >= 0);
  CHECK(rows[2] == -1);
  CHECK(rows[3] == -1);
  nn::SparseGrid twice;
  twice.ijk = {{1, 2, 3}, {1, 2, 3}};
  CHECK_THROWS_WITH_AS(nn::cpu::kernel_map(twice, 3), doctest::Contains("appears twice"), std::invalid_argument);
}

TEST_CASE("sparse cpu: submanifold conv equals dense conv3d over the zero-filled box") {
  std::mt19937 rng(17);
  // Random occupancy, odd channel counts, 3^3 and 1^3 (as a conv) kernels.
  check_conv_against_dense(rng, test::random_sparse_grid(rng, {-5, -3, -7}, {11, 9, 7}, 300), 5, 7, 3);
  check_conv_against_dense(rng, test::random_sparse_grid(rng, {-5, -3, -7}, {11, 9, 7}, 300), 3, 2, 1);
  // Fully dense box: sparse conv is the dense conv with zero padding.
  check_conv_against_dense(rng, nn::dense_box_grid({-2, -2, -2}, {5, 4, 3}, {1, 1, 1}, {0, 0, 0}), 4, 6, 3);
  // A single voxel sees only its centre tap; voxels on brick boundaries and across them.
  check_conv_against_dense(rng, test::random_sparse_grid(rng, {7, 7, 7}, {1, 1, 1}, 1), 3, 3, 3);
  check_conv_against_dense(rng, test::random_sparse_grid(rng, {6, -10, 14}, {4, 4, 4}, 40), 9, 5, 3);
  // 100 km from the origin at 0.2 m: ijk ~ 5e5.
  check_conv_against_dense(rng, test::random_sparse_grid(rng, {500'000, -500'003, 499'990}, {6, 7, 5}, 120), 4, 4, 3);
  // Empty grid.
  const nn::SparseTensor empty = nn::cpu::conv3d(nn::SparseTensor{{}, 4, {}}, random_tensor(rng, {2, 4, 3, 3, 3}), nullptr);
  CHECK(empty.rows() == 0);
  CHECK(empty.channels == 2);
}

TEST_CASE("sparse cpu: kernel map taps in grid order") {
  nn::SparseGrid g;
  g.ijk = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {-1, -1, -1}};
  const std::vector<int32_t> m = nn::cpu::kernel_map(g, 3);
  REQUIRE(m.size() == 4 * 27);
  auto tap = [](int di, int dj, int dk) { return ((di + 1) * 3 + (dj + 1)) * 3 + (dk + 1); };
  CHECK(m[tap(0, 0, 0)] == 0);    // centre
  CHECK(m[tap(1, 0, 0)] == 1);    // +i neighbour
  CHECK(m[tap(0, 0, 1)] == 2);    // +k neighbour
  CHECK(m[tap(-1, -1, -1)] == 3);
  CHECK(m[tap(0, 1, 0)] == -1);
  CHECK(m[27 + tap(-1, 0, 0)] == 0);  // row 1 sees row 0 at -i
}

TEST_CASE("sparse cpu: max pooling onto the coarsened grid, subdivision and pruning") {
  std::mt19937 rng(5);
  const nn::SparseGrid g = test::random_sparse_grid(rng, {-9, -6, -5}, {13, 12, 9}, 250);
  nn::SparseGrid fine = g;
  fine.voxel_size = {0.2, 0.2, 0.2};
  fine.origin = {0.1, 0.1, 0.1};
  const nn::SparseTensor x = random_features(rng, fine, 6, 10.0f);
  for (const Ijk f : {Ijk{2, 2, 1}, Ijk{2, 2, 2}, Ijk{3, 1, 2}}) {
    const nn::SparseTensor y = nn::cpu::max_pool(x, f);
    CHECK(std::is_sorted(y.grid.ijk.begin(), y.grid.ijk.end(), nn::brick_order_less));
    for (int d = 0; d < 3; ++d) {
      CHECK(y.grid.voxel_size[d] == doctest::Approx(0.2 * f[d]));
      CHECK(y.grid.origin[d] == doctest::Approx(0.1 + (f[d] - 1) * 0.1));  // = voxel size / 2 again
    }
    // Brute force: every coarse voxel is the max of the fine voxels with floor(ijk / f) equal to it.
    std::set<Ijk> coarse;
    for (const Ijk& c : x.grid.ijk) coarse.insert({nn::floor_div(c[0], f[0]), nn::floor_div(c[1], f[1]), nn::floor_div(c[2], f[2])});
    REQUIRE(static_cast<size_t>(y.rows()) == coarse.size());
    for (int64_t r = 0; r < y.rows(); ++r)
      for (int64_t ch = 0; ch < x.channels; ++ch) {
        float m = -std::numeric_limits<float>::infinity();
        for (int64_t q = 0; q < x.rows(); ++q) {
          const Ijk& c = x.grid.ijk[static_cast<size_t>(q)];
          if (Ijk{nn::floor_div(c[0], f[0]), nn::floor_div(c[1], f[1]), nn::floor_div(c[2], f[2])} == y.grid.ijk[static_cast<size_t>(r)])
            m = std::max(m, x.row(q)[ch]);
        }
        CHECK(y.row(r)[ch] == m);
      }
  }
  // Subdivision of the kept rows: children ijk * f + o carry the parent's features; pooling them back
  // gives the kept rows again.
  std::vector<uint8_t> keep(static_cast<size_t>(x.rows()));
  for (size_t r = 0; r < keep.size(); ++r) keep[r] = (r % 3) != 0;
  const Ijk f{2, 2, 1};
  const nn::SparseTensor s = nn::cpu::subdivide(x, keep, f);
  const int64_t kept = std::count(keep.begin(), keep.end(), 1);
  CHECK(s.rows() == kept * 4);
  CHECK(s.grid.voxel_size[0] == doctest::Approx(0.1));
  CHECK(s.grid.voxel_size[2] == doctest::Approx(0.2));
  CHECK(s.grid.origin[0] == doctest::Approx(0.05));  // origin - (f - 1) * vs_fine / 2
  CHECK(s.grid.origin[2] == doctest::Approx(0.1));
  const nn::SparseTensor back = nn::cpu::max_pool(s, f);
  CHECK(back.rows() == kept);
  const std::vector<int32_t> rows = nn::cpu::find_rows(x.grid, back.grid.ijk);
  for (int64_t r = 0; r < back.rows(); ++r) {
    REQUIRE(rows[static_cast<size_t>(r)] >= 0);
    CHECK(keep[static_cast<size_t>(rows[static_cast<size_t>(r)])] == 1);
    CHECK(std::equal(back.row(r), back.row(r) + 6, x.row(rows[static_cast<size_t>(r)])));
  }
  // Factor 1 prunes only; keeping nothing gives an empty tensor.
  CHECK(nn::cpu::subdivide(x, keep, {1, 1, 1}).rows() == kept);
  CHECK(nn::cpu::subdivide(x, std::vector<uint8_t>(keep.size(), 0), {2, 2, 2}).rows() == 0);
}

TEST_CASE("sparse cpu: GroupNorm over the active voxels only") {
  std::mt19937 rng(9);
  const nn::SparseGrid g = test::random_sparse_grid(rng, {0, 0, 0}, {9, 9, 9}, 77);
  const nn::SparseTensor x = random_features(rng, g, 8, 50.0f);
  const nn::CpuTensor gamma = random_tensor(rng, {8}), beta = random_tensor(rng, {8});
  const nn::SparseTensor y = nn::cpu::group_norm(x, 4, gamma, beta);
  // The same as torch GroupNorm on (1, C, N): the dense reference on a [1, C, N, 1, 1] tensor.
  nn::CpuTensor t({1, 8, x.rows(), 1, 1});
  for (int64_t r = 0; r < x.rows(); ++r)
    for (int64_t c = 0; c < 8; ++c) t.data[static_cast<size_t>(c * x.rows() + r)] = x.row(r)[c];
  const nn::CpuTensor ref = nn::cpu::group_norm(t, 4, gamma, beta, 1e-5);
  double worst = 0.0;
  for (int64_t r = 0; r < x.rows(); ++r)
    for (int64_t c = 0; c < 8; ++c) worst = std::max(worst, std::abs(double{y.row(r)[c]} - double{ref.data[static_cast<size_t>(c * x.rows() + r)]}));
  CHECK(worst <= 1e-5);
  // A constant input normalises to the bias.
  nn::SparseTensor constant = x;
  std::fill(constant.data.begin(), constant.data.end(), 3.5f);
  const nn::SparseTensor z = nn::cpu::group_norm(constant, 2, gamma, beta);
  for (int64_t r = 0; r < z.rows(); ++r)
    for (int64_t c = 0; c < 8; ++c) CHECK(z.row(r)[c] == doctest::Approx(beta.data[static_cast<size_t>(c)]));
}
