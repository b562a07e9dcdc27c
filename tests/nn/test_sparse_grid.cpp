// GPU sparse grid construction (kernels/nn/sparse_grid.h; shaders nn/sparse_keep,
// nn/sparse_children, nn/sparse_permute, nn/sparse_gather_rows) against the CPU
// reference (nn::cpu::subdivide): the same children in the same brick order,
// each with its parent's features, for factors [2,2,2], [2,2,1] and 1 (pruning),
// negative coordinates, nothing kept, and row gathers with missing rows; max
// pooling (nn/sparse_coarse_keys, nn/sparse_segments, nn/sparse_coarse_rows,
// nn/sparse_max_pool) against nn::cpu::max_pool and hash lookups
// (nn/sparse_lookup) against nn::cpu::find_rows.
// Runs under the validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu_test_context.h"
#include "kernels/nn/sparse_cpu.h"
#include "sparse_test_util.h"
#include "kernels/nn/sparse_conv.h"
#include "kernels/nn/sparse_grid.h"

#include <cmath>
#include <random>
#include <set>

using namespace icube;
using nn::Ijk;

namespace {

void check_subdivide(const nn::SparseGrid& g, const Ijk& f, float keep_fraction, uint32_t seed) {
  CAPTURE(f[0]);
  CAPTURE(f[1]);
  CAPTURE(f[2]);
  CAPTURE(keep_fraction);
  gpu::Context& ctx = test::gpu_context();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const uint32_t n = static_cast<uint32_t>(g.size());
  std::vector<float> logits(2 * size_t{n});  // channel-major [2][n]
  std::vector<uint8_t> keep(n);
  for (uint32_t r = 0; r < n; ++r) {
    const bool k = u(rng) < keep_fraction;
    logits[r] = k ? 0.5f + u(rng) : -u(rng);
    logits[n + r] = 0.0f;
    keep[r] = k;
  }
  // Features: 3 channels identifying the row.
  nn::SparseTensor x{g, 3, {}};
  for (uint32_t r = 0; r < n; ++r) x.data.insert(x.data.end(), {float(r), float(r) * 0.5f, -float(r)});
  const nn::SparseTensor want = nn::cpu::subdivide(x, keep, f);

  std::vector<int32_t> flat;
  for (const Ijk& c : g.ijk) flat.insert(flat.end(), c.begin(), c.end());
  gpu::Buffer ijk = gpu::upload_vector(ctx, flat, "grid-ijk"), lb = gpu::upload_vector(ctx, logits, "grid-logits");
  kernels::nn::SparseGridOps ops(ctx);
  const kernels::nn::SparseGridOps::Children ch = ops.subdivide(ijk, n, lb, f);
  REQUIRE(ch.rows == want.rows());
  if (ch.rows == 0) return;
  const std::vector<int32_t> got_ijk = gpu::download_vector<int32_t>(ctx, ch.ijk, size_t{ch.rows} * 3);
  size_t bad = 0;
  for (uint32_t r = 0; r < ch.rows; ++r)
    for (int d = 0; d < 3; ++d) bad += got_ijk[3 * r + d] != want.grid.ijk[r][d];
  CHECK(bad == 0);
  // Features through the parent rows.
  std::vector<float> x_cm(3 * size_t{n});
  for (uint32_t r = 0; r < n; ++r)
    for (int c = 0; c < 3; ++c) x_cm[c * n + r] = x.row(r)[c];
  gpu::Buffer xb = gpu::upload_vector(ctx, x_cm, "grid-x");
  gpu::Buffer yb(ctx, uint64_t{ch.rows} * 3 * 4, gpu::MemoryUsage::DeviceLocal, "grid-y");
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { ops.record_gather_rows(cmd, xb, n, 3, ch.parent, ch.rows, yb); });
  const std::vector<float> y = gpu::download_vector<float>(ctx, yb, size_t{ch.rows} * 3);
  for (uint32_t r = 0; r < ch.rows; ++r)
    for (int c = 0; c < 3; ++c) bad += y[c * ch.rows + r] != want.row(r)[c];
  CHECK(bad == 0);
}

}  // namespace

TEST_CASE("sparse grid gpu: subdivision and pruning by structure logits equal the CPU reference") {
  const nn::SparseGrid g = test::random_sparse_grid(3, {-20, -17, -9}, {40, 33, 18}, 3000);
  check_subdivide(g, {2, 2, 2}, 0.4f, 1);
  check_subdivide(g, {2, 2, 1}, 0.7f, 2);
  check_subdivide(g, {1, 1, 1}, 0.5f, 3);  // pruning only
  check_subdivide(g, {2, 2, 2}, 0.0f, 4);  // nothing kept
  check_subdivide(g, {2, 2, 2}, 1.0f, 5);
  check_subdivide(test::random_sparse_grid(6, {100'000, -200'000, 50'000}, {9, 9, 9}, 200), {2, 2, 2}, 0.5f, 7);  // far, still < 2^20 after x2
  check_subdivide(test::random_sparse_grid(8, {0, 0, 0}, {1, 1, 1}, 1), {2, 2, 1}, 1.0f, 9);
}

TEST_CASE("sparse grid gpu: the structure decision over logits beyond one storage binding runs in windows of rows") {
  // Bindings capped at 4 KiB (~1,000 floats): 5,003 rows of [2][rows] logits are six windows, channel 1's
  // windows starting off the alignment; ties and NaN drop the voxel as in the CPU rule.
  const uint32_t rows = 5003;
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<float> logits(2 * rows);
  for (float& v : logits) v = u(rng);
  logits[7] = logits[rows + 7];
  logits[4000] = std::nanf("");
  std::vector<uint32_t> want(rows);
  for (uint32_t r = 0; r < rows; ++r) want[r] = logits[r] > logits[rows + r] ? 1u : 0u;
  for (gpu::Context* c : {&test::gpu_context(), &test::capped_gpu_context(4u << 10)}) {
    CAPTURE(c->info().max_storage_buffer_range);
    gpu::Buffer lb = gpu::upload_vector(*c, logits, "keep-logits");
    gpu::Buffer kb(*c, uint64_t{rows} * 4, gpu::MemoryUsage::DeviceLocal, "keep");
    kernels::nn::SparseGridOps ops(*c);
    c->submit_and_wait([&](gpu::CommandList& cmd) { ops.record_keep(cmd, rows, lb, kb); });
    CHECK(test::equal_report(gpu::download_vector<uint32_t>(*c, kb, rows), want, "keep"));
  }
}

TEST_CASE("sparse grid gpu: row gathers with missing rows read zero") {
  gpu::Context& ctx = test::gpu_context();
  const std::vector<float> x{1, 2, 3, 10, 20, 30};  // [2][3]
  const std::vector<int32_t> rows{2, -1, 0, 0};
  gpu::Buffer xb = gpu::upload_vector(ctx, x, "gx"), rb = gpu::upload_vector(ctx, rows, "gr");
  gpu::Buffer yb(ctx, 8 * 4, gpu::MemoryUsage::DeviceLocal, "gy");
  kernels::nn::SparseGridOps ops(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { ops.record_gather_rows(cmd, xb, 3, 2, rb, 4, yb); });
  CHECK(gpu::download_vector<float>(ctx, yb, 8) == std::vector<float>{3, 0, 1, 1, 30, 0, 10, 10});

  // Bindings of 4 KiB: 8 channels of 301 input rows (9,632 B, read as texels) gathered into 517
  // output rows (1 channel a window), and into 3,001 (one output channel is 12 KB: each channel's
  // rows in windows), against the plain loop.
  gpu::Context& capped = test::capped_gpu_context(4u << 10);
  for (const uint32_t out_rows : {517u, 3001u}) {
  CAPTURE(out_rows);
  std::mt19937 rng(12);
  const uint32_t in_rows = 301, channels = 8;
  std::vector<float> xs(size_t{in_rows} * channels);
  for (float& v : xs) v = float(rng() % 100000) - 50000.0f;
  std::vector<int32_t> rs(out_rows);
  for (int32_t& r : rs) r = int32_t(rng() % (in_rows + 20)) - 10;  // negative: missing
  std::vector<float> want(size_t{out_rows} * channels);
  for (uint32_t c = 0; c < channels; ++c)
    for (uint32_t q = 0; q < out_rows; ++q)
      want[c * out_rows + q] = rs[q] >= 0 && rs[q] < int32_t(in_rows) ? xs[c * in_rows + rs[q]] : 0.0f;
  for (int32_t& r : rs) r = r >= int32_t(in_rows) ? -1 : r;
  gpu::Buffer cx = gpu::upload_vector(capped, xs, "gx"), cr = gpu::upload_vector(capped, rs, "gr");
  gpu::Buffer cy(capped, want.size() * 4, gpu::MemoryUsage::DeviceLocal, "gy");
  kernels::nn::SparseGridOps capped_ops(capped);
  capped.submit_and_wait([&](gpu::CommandList& cmd) { capped_ops.record_gather_rows(cmd, cx, in_rows, channels, cr, out_rows, cy); });
  CHECK(test::equal_report(gpu::download_vector<float>(capped, cy, want.size()), want, "capped gather"));
  }
}

TEST_CASE("sparse grid gpu: max pooling (sparse_coarse_keys, sparse_segments, sparse_coarse_rows, sparse_max_pool) and "
          "hash lookups (sparse_lookup) equal the CPU reference") {
  // The device's bindings, and 64 KiB bindings: the 5 channels of ~4,000 fine rows (80 KB) pooled
  // 4 channels a window; the coarse keys sorted in windows.
  for (gpu::Context* pool_ctx : {&test::gpu_context(), &test::capped_gpu_context(64u << 10)}) {
  gpu::Context& ctx = *pool_ctx;
  CAPTURE(ctx.info().max_storage_buffer_range);
  kernels::nn::SparseGridOps ops(ctx);
  for (const Ijk f : {Ijk{2, 2, 1}, Ijk{2, 2, 2}, Ijk{3, 1, 2}}) {
    CAPTURE(f[0]);
    CAPTURE(f[2]);
    const nn::SparseGrid g = test::random_sparse_grid(21 + static_cast<uint32_t>(f[2]), {-23, -9, -14}, {41, 29, 27}, 4000);
    std::mt19937 rng(4);
    std::normal_distribution<float> nd(0.0f, 10.0f);
    nn::SparseTensor x{g, 5, std::vector<float>(static_cast<size_t>(g.size()) * 5)};
    for (float& v : x.data) v = nd(rng);
    const nn::SparseTensor want = nn::cpu::max_pool(x, f);
    const uint32_t n = static_cast<uint32_t>(g.size());
    std::vector<int32_t> flat;
    for (const Ijk& c : g.ijk) flat.insert(flat.end(), c.begin(), c.end());
    std::vector<float> x_cm(x.data.size());
    for (uint32_t r = 0; r < n; ++r)
      for (int c = 0; c < 5; ++c) x_cm[c * n + r] = x.row(r)[c];
    gpu::Buffer ijk = gpu::upload_vector(ctx, flat, "pool-ijk"), xb = gpu::upload_vector(ctx, x_cm, "pool-x");
    const kernels::nn::SparseGridOps::Coarse coarse = ops.coarsen(ijk, n, f);
    REQUIRE(coarse.rows == want.rows());
    gpu::Buffer yb(ctx, uint64_t{coarse.rows} * 5 * 4, gpu::MemoryUsage::DeviceLocal, "pool-y");
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { ops.record_max_pool(cmd, coarse, xb, 5, yb); });
    const std::vector<int32_t> cijk = gpu::download_vector<int32_t>(ctx, coarse.ijk, size_t{coarse.rows} * 3);
    const std::vector<float> y = gpu::download_vector<float>(ctx, yb, size_t{coarse.rows} * 5);
    size_t bad = 0;
    for (uint32_t q = 0; q < coarse.rows; ++q) {
      for (int d = 0; d < 3; ++d) bad += cijk[3 * q + d] != want.grid.ijk[q][d];
      for (int c = 0; c < 5; ++c) bad += y[c * coarse.rows + q] != want.row(q)[c];
    }
    CHECK(bad == 0);
  }
  }
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::SparseGridOps ops(ctx);
  // Lookups of present, absent and far coordinates.
  const nn::SparseGrid g = test::random_sparse_grid(31, {-6, -6, -6}, {12, 12, 12}, 500);
  const uint32_t n = static_cast<uint32_t>(g.size());
  std::vector<int32_t> flat;
  for (const Ijk& c : g.ijk) flat.insert(flat.end(), c.begin(), c.end());
  std::vector<Ijk> queries = nn::dense_box_grid({-7, -7, -7}, {14, 14, 14}, {1, 1, 1}, {0, 0, 0}).ijk;
  queries.push_back({2'000'000'000, 0, -2'000'000'000});
  std::vector<int32_t> qflat;
  for (const Ijk& c : queries) qflat.insert(qflat.end(), c.begin(), c.end());
  gpu::Buffer ijk = gpu::upload_vector(ctx, flat, "lk-ijk"), qb = gpu::upload_vector(ctx, qflat, "lk-q");
  const uint32_t ts = kernels::nn::SparseKernelMap::table_size(n);
  gpu::Buffer table(ctx, uint64_t{ts} * 4, gpu::MemoryUsage::DeviceLocal, "lk-table");
  gpu::Buffer rows(ctx, queries.size() * 4, gpu::MemoryUsage::DeviceLocal, "lk-rows");
  kernels::nn::SparseKernelMap km(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    km.record_clear(cmd, table, ts);
    cmd.barrier(gpu::deps::kTransferToCompute);
    km.record_insert(cmd, n, ijk, table, ts);
    cmd.barrier(gpu::deps::kComputeToCompute);
    ops.record_lookup(cmd, n, ijk, table, ts, static_cast<uint32_t>(queries.size()), qb, rows);
  });
  CHECK(gpu::download_vector<int32_t>(ctx, rows, queries.size()) == nn::cpu::find_rows(g, queries));
}
