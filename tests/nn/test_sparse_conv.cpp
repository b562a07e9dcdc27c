// Sparse kernel maps and submanifold convolution on the GPU
// (kernels/nn/sparse_conv.h; shaders nn/sparse_hash_insert, nn/sparse_kernel_map,
// nn/sparse_conv) against the CPU references (nn::cpu::kernel_map exactly,
// nn::cpu::conv3d within float32 accumulation's bound) on random grids: fully
// dense boxes, a single voxel, voxels across brick boundaries, negative and
// far-from-origin (100 km at 0.2 m) coordinates, channel counts that are not
// multiples of the 8-channel tile, windows of channels, extreme values; every
// path (the register tile, sparse_conv_tiled, sparse_conv_coopmat and, on
// lavapipe, its emulated fragments) in fp32 and fp16 weights, against the
// reference on the operands the kernel reads (fp16-rounded weights; inputs too
// on the cooperative-matrix paths); the input stored as fp16 (SparseConvShape::f16_input,
// R16_SFLOAT texels) on every path, against the reference on the rounded input.
// Runs under the validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu_test_context.h"
#include "kernels/nn/conv3d.h"
#include "gpu/device_info.h"
#include "kernels/nn/float16.h"
#include "kernels/nn/sparse_conv.h"
#include "kernels/nn/sparse_cpu.h"
#include "half_values.h"
#include "sparse_test_util.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <set>
#include <string>

using namespace icube;
using nn::Ijk;

namespace {

std::vector<int32_t> flat_ijk(const nn::SparseGrid& g) {
  std::vector<int32_t> v;
  for (const Ijk& c : g.ijk) v.insert(v.end(), c.begin(), c.end());
  return v;
}

// The GPU kernel map of `g`.
std::vector<int32_t> gpu_kernel_map(const nn::SparseGrid& g, gpu::Context& ctx = test::gpu_context()) {
  const uint32_t rows = static_cast<uint32_t>(g.size());
  const uint32_t ts = kernels::nn::SparseKernelMap::table_size(rows);
  gpu::Buffer ijk = gpu::upload_vector(ctx, flat_ijk(g).empty() ? std::vector<int32_t>{0, 0, 0} : flat_ijk(g), "sparse-ijk");
  gpu::Buffer table(ctx, uint64_t{ts} * 4, gpu::MemoryUsage::DeviceLocal, "sparse-table");
  gpu::Buffer kmap(ctx, std::max<uint64_t>(4, uint64_t{rows} * 27 * 4), gpu::MemoryUsage::DeviceLocal, "sparse-kmap");
  kernels::nn::SparseKernelMap km(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    km.record_clear(cmd, table, ts);
    cmd.barrier(gpu::deps::kTransferToCompute);
    km.record_insert(cmd, rows, ijk, table, ts);
    cmd.barrier(gpu::deps::kComputeToCompute);
    km.record_map(cmd, rows, ijk, table, ts, kmap);
  });
  return rows ? gpu::download_vector<int32_t>(ctx, kmap, uint64_t{rows} * 27) : std::vector<int32_t>{};
}

// GPU conv of x (CPU layout [N, C]) vs the CPU reference; bound 1e-6 + n * 2^-23 * sum |w x|. With
// f16_weights the weights are packed as fp16; the reference then convolves the fp16-rounded weights, and
// on the cooperative-matrix paths (fp16 operands) the fp16-rounded inputs too.
void check_conv(const nn::SparseGrid& g, int64_t ci, int64_t co, bool with_bias, float scale, uint32_t seed,
                uint64_t max_binding_bytes = 0, bool silu = false, gpu::Context& ctx = test::gpu_context(),
                std::optional<kernels::nn::Conv3dPath> path = std::nullopt, bool f16_weights = false,
                bool f16_input = false) {
  CAPTURE(g.size());
  CAPTURE(f16_input);
  CAPTURE(ci);
  CAPTURE(co);
  CAPTURE(f16_weights);
  CAPTURE(ctx.info().max_storage_buffer_range);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  nn::SparseTensor x{g, ci, std::vector<float>(static_cast<size_t>(g.size() * ci))};
  for (float& v : x.data) v = scale * u(rng);
  nn::CpuTensor w({co, ci, 3, 3, 3}), b({co});
  for (float& v : w.data) v = 0.5f * u(rng);
  for (float& v : b.data) v = u(rng);
  const bool f16_operands = path && kernels::nn::conv3d_path_rounds_activations(*path);
  if (f16_operands || f16_input)  // an fp16 input is stored rounded; the tensor cores round their operands
    for (float& v : x.data) v = test::round_to_half(v);
  if (f16_weights || f16_operands)
    for (float& v : w.data) v = test::round_to_half(v);
  const nn::SparseTensor want =
      silu ? nn::cpu::silu(nn::cpu::conv3d(x, w, with_bias ? &b : nullptr)) : nn::cpu::conv3d(x, w, with_bias ? &b : nullptr);
  nn::SparseTensor ax = x;
  for (float& v : ax.data) v = std::abs(v);
  nn::CpuTensor aw = w;
  for (float& v : aw.data) v = std::abs(v);
  const nn::SparseTensor bound = nn::cpu::conv3d(ax, aw, nullptr);

  const uint32_t rows = static_cast<uint32_t>(g.size());
  std::vector<float> x_cm(x.data.size());  // channel-major [C][N]
  for (int64_t r = 0; r < x.rows(); ++r)
    for (int64_t c = 0; c < ci; ++c) x_cm[static_cast<size_t>(c * rows + r)] = x.row(r)[c];
  const std::vector<int32_t> kmap_host = nn::cpu::kernel_map(g, 3);
  gpu::Buffer xb = f16_input ? gpu::upload_vector(ctx, test::to_halves(x_cm), "sparse-x16")
                             : gpu::upload_vector(ctx, x_cm, "sparse-x");
  gpu::Buffer kb = gpu::upload_vector(ctx, kmap_host, "sparse-kmap");
  const uint32_t co32 = static_cast<uint32_t>(co), ci32 = static_cast<uint32_t>(ci);
  gpu::Buffer wb = f16_weights ? gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights_f16(w.data, co32, ci32, 3), "sparse-w")
                               : gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights(w.data, co32, ci32, 3), "sparse-w");
  gpu::Buffer bb = gpu::upload_vector(ctx, b.data, "sparse-b");
  gpu::Buffer yb(ctx, uint64_t{rows} * static_cast<uint64_t>(co) * 4, gpu::MemoryUsage::DeviceLocal, "sparse-y");
  kernels::nn::SparseConv3d conv(ctx);
  conv.set_max_binding_bytes(max_binding_bytes);
  conv.force_path(path);
  const kernels::nn::SparseConvShape s{rows, ci32, co32, silu, f16_weights, f16_input};
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, xb, kb, wb, with_bias ? &bb : nullptr, yb); });
  const std::vector<float> got = gpu::download_vector<float>(ctx, yb, uint64_t{rows} * static_cast<uint64_t>(co));
  const double n = static_cast<double>(ci) * 27.0;
  size_t bad = 0;
  for (int64_t r = 0; r < want.rows(); ++r)
    for (int64_t c = 0; c < co; ++c) {
      const double ref = want.row(r)[c], gv = got[static_cast<size_t>(c * rows + r)];
      const double tol = (1e-6 + n * std::ldexp(1.0, -23) * static_cast<double>(bound.row(r)[c])) * (silu ? 1.1 : 1.0) + (silu ? 1e-6 : 0.0);
      if (!(std::abs(gv - ref) <= tol) && ++bad <= 5)
        std::printf("  sparse conv mismatch row %lld channel %lld: got %.9g want %.9g (tol %.3g)\n", static_cast<long long>(r),
                    static_cast<long long>(c), gv, ref, tol);
    }
  CHECK(bad == 0);
}

}  // namespace

TEST_CASE("sparse conv gpu: the hashed kernel map equals the CPU reference exactly") {
  const std::vector<nn::SparseGrid> grids = {
      test::random_sparse_grid(1, {-20, -9, -13}, {41, 23, 29}, 5000),                   // random occupancy, negative coordinates
      nn::dense_box_grid({-3, 5, -2}, {9, 7, 5}, {1, 1, 1}, {0, 0, 0}),      // fully dense: 27 neighbours inside
      test::random_sparse_grid(2, {7, 7, 7}, {1, 1, 1}, 1),                               // one voxel: only its centre
      test::random_sparse_grid(3, {6, 14, -10}, {4, 4, 4}, 40),                           // across brick boundaries
      test::random_sparse_grid(4, {500'000, -500'003, 499'990}, {16, 9, 7}, 600),         // 100 km from the origin at 0.2 m
      test::random_sparse_grid(5, {-2'000'000'000, 2'000'000'000, -5}, {5, 5, 5}, 60),    // int32 extremes (no wrap needed)
  };
  for (const nn::SparseGrid& g : grids) {
    CAPTURE(g.size());
    const std::vector<int32_t> got = gpu_kernel_map(g), want = nn::cpu::kernel_map(g, 3);
    REQUIRE(got.size() == want.size());
    size_t bad = 0;
    for (size_t i = 0; i < got.size(); ++i)
      if (got[i] != want[i] && ++bad <= 5)
        std::printf("  kernel map mismatch at row %zu tap %zu: got %d want %d\n", i / 27, i % 27, got[i], want[i]);
    CHECK(bad == 0);
  }
  CHECK(gpu_kernel_map(nn::SparseGrid{}).empty());
  CHECK(kernels::nn::SparseKernelMap::table_size(0) == 64);
  CHECK(kernels::nn::SparseKernelMap::table_size(33) == 128);
  CHECK(kernels::nn::SparseKernelMap::table_size(1'000'000) == (1u << 21));
}

TEST_CASE("sparse conv gpu: submanifold 3x3x3 against the CPU reference") {
  check_conv(test::random_sparse_grid(11, {-9, -5, -7}, {19, 13, 11}, 900), 13, 19, true, 1.0f, 21);   // odd channel counts
  check_conv(nn::dense_box_grid({0, 0, 0}, {6, 5, 7}, {1, 1, 1}, {0, 0, 0}), 8, 16, false, 1.0f, 22);
  check_conv(test::random_sparse_grid(12, {3, 3, 3}, {1, 1, 1}, 1), 4, 3, true, 1.0f, 23);                // a single voxel
  check_conv(test::random_sparse_grid(13, {500'000, -500'003, 499'990}, {9, 8, 7}, 200), 6, 5, true, 1.0f, 24);
  check_conv(test::random_sparse_grid(14, {-4, -4, -4}, {8, 8, 8}, 300), 5, 9, true, 1e4f, 25);          // large activations
  check_conv(test::random_sparse_grid(15, {-30, -30, -10}, {60, 60, 20}, 2000), 32, 64, true, 1.0f, 26); // the VAE's widths
  check_conv(test::random_sparse_grid(16, {-9, -5, -7}, {19, 13, 11}, 700), 12, 9, true, 3.0f, 27, 0, true);  // fused SiLU
}

TEST_CASE("sparse conv gpu: channel windows when the features exceed one binding") {
  // 2 KiB bindings: 40 rows x 12 channels run as windows of 8 output and 12 input channels.
  check_conv(test::random_sparse_grid(31, {-5, -5, -5}, {10, 10, 10}, 40), 30, 20, true, 1.0f, 32, 2048);
  check_conv(test::random_sparse_grid(34, {-5, -5, -5}, {10, 10, 10}, 40), 30, 20, true, 1.0f, 35, 2048, true);  // SiLU on the last window
  // A binding of under 8 channel planes (40 rows x 4 channels of the window fit, not 8): windows of
  // 4 output channels (the case of a 7.3 M-row decoded chunk on lavapipe's 128 MiB).
  check_conv(test::random_sparse_grid(36, {-5, -5, -5}, {10, 10, 10}, 40), 9, 13, true, 1.0f, 37, 4 * 40 * 4 + 64);
  check_conv(test::random_sparse_grid(38, {-5, -5, -5}, {10, 10, 10}, 40), 6, 5, true, 1.0f, 39, 4 * 40 * 4 + 64, true);
  const nn::SparseGrid g = test::random_sparse_grid(33, {0, 0, 0}, {4, 4, 4}, 10);
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::SparseConv3d conv(ctx);
  gpu::Buffer small(ctx, 64, gpu::MemoryUsage::DeviceLocal, "small");
  const kernels::nn::SparseConvShape s{10, 4, 4};
  CHECK_THROWS_WITH_AS(ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, small, small, small, nullptr, small); }),
                       doctest::Contains("sparse conv: input buffer holds 64 bytes"), std::invalid_argument);
}

// A GPU path forced on the test device, fp32 and fp16 weights: odd channel counts across the 64 x 64
// blocks, a single voxel, 100 km from the origin, large activations, the VAE's widths, fused SiLU, channel
// windows (of 4 output channels: with fp16 weights every other one starts inside a vector of 8 halves)
// and a capped binding.
void check_sparse_gpu_path(kernels::nn::Conv3dPath path, const char* shader, const char* shader_f16w) {
  CHECK(std::string(kernels::nn::SparseConv3d::shader_name(path, false)) == shader);
  CHECK(std::string(kernels::nn::SparseConv3d::shader_name(path, true)) == shader_f16w);
  gpu::Context& ctx = test::gpu_context();
  for (const bool f16 : {false, true}) {
    const uint32_t o = f16 ? 100 : 0;  // other seeds for the fp16 weights
    check_conv(test::random_sparse_grid(11, {-9, -5, -7}, {19, 13, 11}, 900), 13, 19, true, 1.0f, 51 + o, 0, false, ctx, path, f16);
    check_conv(test::random_sparse_grid(12, {3, 3, 3}, {1, 1, 1}, 1), 4, 3, true, 1.0f, 52 + o, 0, false, ctx, path, f16);
    check_conv(test::random_sparse_grid(13, {500'000, -500'003, 499'990}, {9, 8, 7}, 200), 6, 70, true, 1.0f, 53 + o, 0, false,
               ctx, path, f16);
    check_conv(test::random_sparse_grid(14, {-4, -4, -4}, {8, 8, 8}, 300), 5, 9, true, 1e4f, 54 + o, 0, false, ctx, path, f16);
    check_conv(test::random_sparse_grid(15, {-30, -30, -10}, {60, 60, 20}, 2000), 32, 64, true, 1.0f, 55 + o, 0, false, ctx,
               path, f16);
    check_conv(test::random_sparse_grid(16, {-9, -5, -7}, {19, 13, 11}, 700), 12, 9, true, 3.0f, 56 + o, 0, true, ctx, path, f16);
    check_conv(test::random_sparse_grid(31, {-5, -5, -5}, {10, 10, 10}, 40), 30, 20, true, 1.0f, 57 + o, 2048, true, ctx, path,
               f16);
    check_conv(test::random_sparse_grid(36, {-5, -5, -5}, {10, 10, 10}, 40), 9, 13, true, 1.0f, 58 + o, 4 * 40 * 4 + 64, false,
               ctx, path, f16);
    gpu::Context& capped = test::capped_gpu_context(8u << 10);
    check_conv(test::random_sparse_grid(41, {-9, -9, -9}, {18, 18, 18}, 500), 13, 20, true, 1.0f, 59 + o, 0, false, capped, path,
               f16);
  }
  // More input channels than one dispatch of the emulated fragments takes (48): windows that accumulate.
  if (path == kernels::nn::Conv3dPath::kCoopMatrixEmulated)
    check_conv(test::random_sparse_grid(17, {-4, -4, -4}, {8, 8, 8}, 120), 100, 12, true, 1.0f, 60, 0, true, ctx, path);
}

TEST_CASE("sparse conv gpu: fp16 weight storage (sparse_conv_f16w) equals the fp32 kernel on fp16-rounded weights") {
  CHECK(std::string(kernels::nn::SparseConv3d::shader_name(kernels::nn::Conv3dPath::kRegisterTile, true)) ==
        "nn/sparse_conv_f16w");
  const auto reg = kernels::nn::Conv3dPath::kRegisterTile;
  gpu::Context& ctx = test::gpu_context();
  check_conv(test::random_sparse_grid(11, {-9, -5, -7}, {19, 13, 11}, 900), 13, 19, true, 1.0f, 71, 0, false, ctx, reg, true);
  check_conv(test::random_sparse_grid(15, {-30, -30, -10}, {60, 60, 20}, 2000), 32, 64, true, 1.0f, 72, 0, true, ctx, reg, true);
  // Output windows of 4 channels: every other one starts in the middle of a vector of 8 halves (co_lead 4).
  check_conv(test::random_sparse_grid(36, {-5, -5, -5}, {10, 10, 10}, 40), 9, 13, true, 1.0f, 73, 4 * 40 * 4 + 64, false, ctx,
             reg, true);
  check_conv(test::random_sparse_grid(38, {-5, -5, -5}, {10, 10, 10}, 40), 6, 5, true, 1.0f, 75, 4 * 40 * 4 + 64, true, ctx,
             reg, true);
  check_conv(test::random_sparse_grid(41, {-9, -9, -9}, {18, 18, 18}, 500), 13, 20, true, 1.0f, 74, 0, false,
             test::capped_gpu_context(8u << 10), reg, true);
}

TEST_CASE("sparse conv gpu: an fp16 input (a GroupNorm's fp16 output) on every path, in one binding and in windows") {
  using P = kernels::nn::Conv3dPath;
  gpu::Context& ctx = test::gpu_context();
  std::vector<P> paths = {P::kRegisterTile, P::kSharedTile};
  if (ctx.info().shader_float16) paths.push_back(P::kCoopMatrixEmulated);
  if (ctx.info().cooperative_matrix_nv) paths.push_back(P::kCoopMatrix);
  for (const P path : paths) {
    check_conv(test::random_sparse_grid(11, {-9, -5, -7}, {19, 13, 11}, 900), 13, 19, true, 1.0f, 81, 0, false, ctx, path, true,
               true);
    check_conv(test::random_sparse_grid(13, {500'000, -500'003, 499'990}, {9, 8, 7}, 200), 6, 70, true, 1.0f, 82, 0, true, ctx,
               path, false, true);
    check_conv(test::random_sparse_grid(14, {-4, -4, -4}, {8, 8, 8}, 300), 5, 9, true, 1e4f, 83, 0, false, ctx, path, true, true);
    // Input windows of 2-byte elements at texel offsets off the alignment, 4-channel output windows.
    check_conv(test::random_sparse_grid(31, {-5, -5, -5}, {10, 10, 10}, 40), 30, 20, true, 1.0f, 84, 2048, true, ctx, path, true,
               true);
    check_conv(test::random_sparse_grid(41, {-9, -9, -9}, {18, 18, 18}, 500), 13, 20, true, 1.0f, 85, 0, false,
               test::capped_gpu_context(8u << 10), path, true, true);
  }
}

TEST_CASE("sparse conv gpu: sparse_conv_tiled (the shared-memory gathered implicit GEMM) against the CPU reference") {
  check_sparse_gpu_path(kernels::nn::Conv3dPath::kSharedTile, "nn/sparse_conv_tiled", "nn/sparse_conv_tiled_f16w");
}

TEST_CASE("sparse conv gpu: sparse_conv_coopmat_emulated (the cooperative-matrix tiling, emulated fragments) against the CPU reference") {
  if (!test::gpu_context().info().shader_float16) {
    MESSAGE("skipped: the test device has no shaderFloat16");
    return;
  }
  check_sparse_gpu_path(kernels::nn::Conv3dPath::kCoopMatrixEmulated, "nn/sparse_conv_coopmat_emulated",
                        "nn/sparse_conv_coopmat_emulated_f16w");
}

TEST_CASE("sparse conv gpu: sparse_conv_coopmat (the cooperative-matrix kernel) on a device that has it") {
  // lavapipe has no cooperative matrices: this runs on tools/device-check.sh's lease, where a wrong
  // result fails the check; elsewhere asking for the path is refused with the reason.
  gpu::Context& ctx = test::gpu_context();
  if (!ctx.info().cooperative_matrix_nv) {
    kernels::nn::SparseConv3d conv(ctx);
    conv.force_path(kernels::nn::Conv3dPath::kCoopMatrix);
    gpu::Buffer any(ctx, 4096, gpu::MemoryUsage::DeviceLocal, "any");
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      CHECK_THROWS_WITH_AS(conv.record(cmd, {4, 2, 2, false, true}, any, any, any, nullptr, any),
                           doctest::Contains("no VK_NV_cooperative_matrix"), std::invalid_argument);
    });
    MESSAGE("the real fragments are checked on a device with VK_NV_cooperative_matrix (tools/device-check.sh)");
    return;
  }
  check_sparse_gpu_path(kernels::nn::Conv3dPath::kCoopMatrix, "nn/sparse_conv_coopmat", "nn/sparse_conv_coopmat_f16w");
  // The VAE's widest level at a real size: 128 -> 128 channels over 60,000 rows.
  check_conv(test::random_sparse_grid(18, {-60, -60, -20}, {120, 120, 40}, 60'000), 128, 128, true, 1.0f, 61, 0, true, ctx,
             kernels::nn::Conv3dPath::kCoopMatrix, true);
}

TEST_CASE("sparse conv gpu: the default path per device and precision, as conv3d's") {
  gpu::DeviceInfo cpu, gpu_nv;
  cpu.type = VK_PHYSICAL_DEVICE_TYPE_CPU;
  gpu_nv.type = VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU;
  gpu_nv.cooperative_matrix_nv = true;
  gpu_nv.subgroup_size = 32;
  using P = kernels::nn::Conv3dPath;
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::SparseConv3d conv(ctx);
  for (const bool f16 : {false, true}) CHECK(conv.path(f16) == kernels::nn::default_conv3d_path(ctx.info(), f16));
  conv.force_path(P::kSharedTile);
  CHECK(conv.path(true) == P::kSharedTile);
  CHECK(kernels::nn::default_conv3d_path(cpu, true) == P::kRegisterTile);
  CHECK(kernels::nn::default_conv3d_path(gpu_nv, true) == P::kCoopMatrix);
}

TEST_CASE("sparse conv gpu: kernel-map rows, features and weights over a forced 8 KiB binding") {
  // A context whose bindings hold 8 KiB: the kernel map of 500 rows (54 KB) is written in windows of
  // 72 rows; the convolution reads it in those row windows, its features 4 channels a window and
  // its packed weights (2,592 B an input channel at 20 outputs) 3 input channels a window.
  gpu::Context& capped = test::capped_gpu_context(8u << 10);
  const nn::SparseGrid g = test::random_sparse_grid(41, {-9, -9, -9}, {18, 18, 18}, 500);
  CHECK(gpu_kernel_map(g, capped) == nn::cpu::kernel_map(g, 3));
  check_conv(g, 13, 20, true, 1.0f, 42, 0, false, capped);
  check_conv(g, 7, 9, false, 3.0f, 43, 0, true, capped);
  // One input channel's weights at 4,096 outputs (27 x 1,024 vec4s = 442 KB) cannot be windowed: named.
  kernels::nn::SparseConv3d conv(capped);
  gpu::Buffer big(capped, 27u * 1024 * 16 * 2, gpu::MemoryUsage::DeviceLocal, "big");
  const kernels::nn::SparseConvShape s{2, 2, 4096};
  CHECK_THROWS_WITH_AS(capped.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, big, big, big, nullptr, big); }),
                       doctest::Contains("use fewer output channels"), std::invalid_argument);
}

TEST_CASE("sparse conv gpu: equals the dense GPU conv3d over the zero-filled box at the active voxels") {
  gpu::Context& ctx = test::gpu_context();
  const nn::Ijk dims{13, 11, 9};
  const nn::SparseGrid g = test::random_sparse_grid(41, {0, 0, 0}, dims, 400);
  const uint32_t n = static_cast<uint32_t>(g.size()), ci = 6, co = 10;
  const uint64_t V = uint64_t{13} * 11 * 9;
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> xs(uint64_t{ci} * n), w(uint64_t{co} * ci * 27), b(co), xd(uint64_t{ci} * V, 0.0f);
  for (float& v : xs) v = u(rng);
  for (float& v : w) v = u(rng);
  for (float& v : b) v = u(rng);
  auto voxel = [&](uint32_t r) { return (uint64_t(g.ijk[r][0]) * dims[1] + uint64_t(g.ijk[r][1])) * dims[2] + uint64_t(g.ijk[r][2]); };
  for (uint32_t r = 0; r < n; ++r)
    for (uint32_t c = 0; c < ci; ++c) xd[c * V + voxel(r)] = xs[uint64_t{c} * n + r];
  const std::vector<float> packed = kernels::nn::pack_conv3d_weights(w, co, ci, 3);
  gpu::Buffer xb = gpu::upload_vector(ctx, xs, "sd-x"), xdb = gpu::upload_vector(ctx, xd, "sd-xd");
  gpu::Buffer wb = gpu::upload_vector(ctx, packed, "sd-w"), bb = gpu::upload_vector(ctx, b, "sd-b");
  gpu::Buffer kb = gpu::upload_vector(ctx, nn::cpu::kernel_map(g, 3), "sd-kmap");
  gpu::Buffer yb(ctx, uint64_t{co} * n * 4, gpu::MemoryUsage::DeviceLocal, "sd-y"), ydb(ctx, uint64_t{co} * V * 4, gpu::MemoryUsage::DeviceLocal, "sd-yd");
  kernels::nn::SparseConv3d sconv(ctx);
  kernels::nn::Conv3d dconv(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    sconv.record(cmd, {n, ci, co}, xb, kb, wb, &bb, yb);
    dconv.record(cmd, {1, ci, co, 13, 11, 9, 3, false}, xdb, wb, &bb, ydb);
  });
  const std::vector<float> ys = gpu::download_vector<float>(ctx, yb, uint64_t{co} * n), yd = gpu::download_vector<float>(ctx, ydb, uint64_t{co} * V);
  double worst = 0.0;
  for (uint32_t r = 0; r < n; ++r)
    for (uint32_t c = 0; c < co; ++c) worst = std::max(worst, std::abs(double{ys[uint64_t{c} * n + r]} - double{yd[c * V + voxel(r)]}));
  CHECK(worst < 1e-5);
}
