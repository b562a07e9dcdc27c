// conv3d on the GPU (kernels/nn/conv3d.h, shaders/nn/conv3d.comp; with fp16
// weights shaders/nn/conv3d_f16w.comp, against the reference on fp16-rounded weights; the GPUs'
// kernels conv3d_tiled(_f16w), conv3d_coopmat(_f16w) and, on lavapipe, conv3d_coopmat_emulated(_f16w),
// forced) against the
// CPU reference (nn::cpu::conv3d) on odd sizes, batch 2, channel counts that
// are not multiples of the 8-channel tile, 1x1 and 3x3x3 kernels, without bias
// and with large activations. The bound per element is float32 accumulation's:
// 1e-6 + n * 2^-23 * sum |w x| over the n = Ci * k^3 products (computed by the
// reference on |x| and |w|). The input stored as fp16 (Conv3dShape::f16_input, read as
// R16_SFLOAT texels) on every path, in one binding and in windows, against the reference on the
// rounded input. Runs under the validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu/device_info.h"
#include "gpu_test_context.h"
#include "kernels/nn/conv3d.h"
#include "kernels/nn/float16.h"
#include "half_values.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <string>

using namespace icube;

namespace {

nn::CpuTensor random_tensor(std::vector<int64_t> shape, uint32_t seed, float scale) {
  nn::CpuTensor t(std::move(shape));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-scale, scale);
  for (float& v : t.data) v = u(rng);
  return t;
}

nn::CpuTensor abs_of(nn::CpuTensor t) {
  for (float& v : t.data) v = std::abs(v);
  return t;
}

void check_conv(const kernels::nn::Conv3dShape& s, bool with_bias, float x_scale, uint32_t seed,
                uint64_t max_binding_bytes = 0, gpu::Context& ctx = test::gpu_context(),
                std::optional<kernels::nn::Conv3dPath> path = std::nullopt) {
  if (path) CAPTURE(kernels::nn::conv3d_path_name(*path));
  CAPTURE(ctx.info().max_storage_buffer_range);
  CAPTURE(s.batch);
  CAPTURE(s.in_channels);
  CAPTURE(s.out_channels);
  CAPTURE(s.kernel);
  CAPTURE(s.f16_weights);
  CAPTURE(s.f16_input);
  nn::CpuTensor x = random_tensor({s.batch, s.in_channels, s.x, s.y, s.z}, seed, x_scale);
  if (s.f16_input)  // the kernel reads the operand as stored: rounded to fp16
    for (float& v : x.data) v = test::round_to_half(v);
  const int64_t k = s.kernel;
  nn::CpuTensor w = random_tensor({s.out_channels, s.in_channels, k, k, k}, seed + 1, 0.5f);
  // The cooperative-matrix kernels multiply fp16 operands (exact products, fp32 sums): the reference
  // convolves the rounded inputs, so the bound stays fp32 accumulation's.
  const bool f16_operands = path && kernels::nn::conv3d_path_rounds_activations(*path);
  nn::CpuTensor x_gpu = x;
  if (f16_operands)
    for (float& v : x.data) v = test::round_to_half(v);
  if (s.f16_weights || f16_operands)  // the reference convolves the weights the kernel reads: rounded to fp16
    for (float& v : w.data) v = test::round_to_half(v);
  const nn::CpuTensor b = random_tensor({s.out_channels}, seed + 2, 1.0f);
  const nn::CpuTensor want = nn::cpu::conv3d(x, w, with_bias ? &b : nullptr, 1, static_cast<int>(k / 2));
  const nn::CpuTensor bound = nn::cpu::conv3d(abs_of(x), abs_of(w), nullptr, 1, static_cast<int>(k / 2));

  gpu::Buffer xb = s.f16_input ? gpu::upload_vector(ctx, test::to_halves(x_gpu.data), "conv-x16")
                               : gpu::upload_vector(ctx, x_gpu.data, "conv-x");
  gpu::Buffer wb =
      s.f16_weights
          ? gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights_f16(w.data, s.out_channels, s.in_channels, s.kernel),
                               "conv-w16")
          : gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights(w.data, s.out_channels, s.in_channels, s.kernel),
                               "conv-w");
  gpu::Buffer bb = gpu::upload_vector(ctx, b.data, "conv-b");
  gpu::Buffer yb(ctx, want.data.size() * 4, gpu::MemoryUsage::DeviceLocal, "conv-y");
  kernels::nn::Conv3d conv(ctx);
  conv.set_max_binding_bytes(max_binding_bytes);
  conv.force_path(path);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, xb, wb, with_bias ? &bb : nullptr, yb); });
  const std::vector<float> got = gpu::download_vector<float>(ctx, yb, want.data.size());
  const double n = static_cast<double>(s.in_channels) * static_cast<double>(k * k * k);
  size_t bad = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const double tol = 1e-6 + n * std::ldexp(1.0, -23) * static_cast<double>(bound.data[i]);
    const double err = std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i]));
    if (!(err <= tol) && ++bad <= 5)
      std::printf("  conv3d mismatch at %zu: got %.9g want %.9g (tol %.3g)\n", i, static_cast<double>(got[i]),
                  static_cast<double>(want.data[i]), tol);
  }
  CHECK(bad == 0);
}

}  // namespace

TEST_CASE("conv3d gpu: 3x3x3 and 1x1 against the CPU reference at odd sizes and channel counts") {
  check_conv({2, 3, 5, 5, 4, 7, 3}, true, 1.0f, 11);      // batch 2, Co not a tile multiple, odd grid
  check_conv({1, 16, 32, 8, 16, 24, 3}, true, 1.0f, 21);  // unet_small's first level
  check_conv({1, 7, 9, 3, 5, 2, 1}, true, 1.0f, 31);      // 1x1 skip
  check_conv({1, 4, 8, 1, 1, 1, 3}, false, 1.0f, 41);     // a single voxel: only the centre tap
  // The released model's widest input (a 768-channel level concatenated with its skip) and beyond
  // the per-dispatch channel window: lavapipe stops an invocation after 65,535 loop iterations.
  check_conv({1, 1536, 8, 3, 2, 9, 3}, true, 1.0f, 51);
  check_conv({1, 4100, 9, 2, 1, 3, 3}, true, 1.0f, 61);
  check_conv({1, 8, 16, 9, 3, 33, 3}, true, 3e4f, 51);    // large activations, more than one voxel tile
}

// The discrete-GPU kernels, forced on the test device (lavapipe runs their shared memory and barriers,
// slowly): odd grids and channel counts across the 64 x 64 block edges, batch 2, both kernel sizes, fp16
// weights, large activations, input-channel windows that accumulate and a capped binding.
void check_gpu_path(kernels::nn::Conv3dPath path, const char* shader, const char* shader_f16w) {
  using S = kernels::nn::Conv3dShape;
  CHECK(std::string(kernels::nn::Conv3d::shader_name(path, false)) == shader);
  CHECK(std::string(kernels::nn::Conv3d::shader_name(path, true)) == shader_f16w);
  const bool emulated = path == kernels::nn::Conv3dPath::kCoopMatrixEmulated;
  check_conv(S{2, 3, 5, 5, 4, 7, 3}, true, 1.0f, 111, 0, test::gpu_context(), path);
  check_conv(S{1, 16, 70, 9, 3, 5, 3}, true, 1.0f, 112, 0, test::gpu_context(), path);  // 2 channel blocks, 3 voxel tiles
  check_conv(S{1, 7, 9, 3, 5, 2, 1}, true, 1.0f, 113, 0, test::gpu_context(), path);    // 1x1, K = 7 < one K step
  check_conv(S{1, 4, 8, 1, 1, 1, 3}, false, 1.0f, 114, 0, test::gpu_context(), path);   // a single voxel
  check_conv(S{2, 3, 5, 5, 4, 7, 3, true}, true, 1.0f, 115, 0, test::gpu_context(), path);
  check_conv(S{1, 37, 24, 6, 5, 7, 3, true}, true, 1.0f, 116, 0, test::gpu_context(), path);
  // Large activations (fp16 operands: 3e4 stays below 65504).
  check_conv(S{1, 8, 16, 9, 3, 33, 3}, true, 3e4f, 117, 0, test::gpu_context(), path);
  // More input channels than one dispatch takes on the emulated path (48): windows that accumulate.
  if (emulated) check_conv(S{1, 100, 12, 3, 4, 5, 3}, true, 1.0f, 118, 0, test::gpu_context(), path);
  // Binding windows: per-channel x and y windows at unaligned offsets, and weight windows.
  const uint64_t per_channel = 5 * 6 * 7 * 4;
  const uint64_t align = std::max<uint64_t>(4, test::gpu_context().info().min_storage_buffer_offset_alignment);
  check_conv(S{2, 19, 21, 5, 6, 7, 3}, true, 1.0f, 119, per_channel * 9 + align, test::gpu_context(), path);
  check_conv(S{1, 19, 21, 5, 6, 7, 3, true}, true, 1.0f, 120, 0, test::capped_gpu_context(16u << 10), path);
}

TEST_CASE("conv3d gpu: conv3d_tiled and conv3d_tiled_f16w (the shared-memory kernel) against the CPU reference") {
  check_gpu_path(kernels::nn::Conv3dPath::kSharedTile, "nn/conv3d_tiled", "nn/conv3d_tiled_f16w");
}

TEST_CASE("conv3d gpu: conv3d_coopmat_emulated and conv3d_coopmat_emulated_f16w (the cooperative-matrix tiling, emulated fragments) against the CPU reference") {
  if (!test::gpu_context().info().shader_float16) {
    MESSAGE("skipped: the test device has no shaderFloat16");
    return;
  }
  check_gpu_path(kernels::nn::Conv3dPath::kCoopMatrixEmulated, "nn/conv3d_coopmat_emulated",
                 "nn/conv3d_coopmat_emulated_f16w");
}

TEST_CASE("conv3d gpu: conv3d_coopmat and conv3d_coopmat_f16w (the cooperative-matrix kernel) on a device that has it") {
  // lavapipe has no cooperative matrices: this runs on tools/device-check.sh's lease, where a wrong
  // result fails the check; elsewhere asking for the path is refused with the reason.
  gpu::Context& ctx = test::gpu_context();
  if (!ctx.info().cooperative_matrix_nv) {
    kernels::nn::Conv3d conv(ctx);
    conv.force_path(kernels::nn::Conv3dPath::kCoopMatrix);
    gpu::Buffer any(ctx, 4096, gpu::MemoryUsage::DeviceLocal, "any");
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      CHECK_THROWS_WITH_AS(conv.record(cmd, {1, 2, 2, 2, 2, 2, 3}, any, any, nullptr, any),
                           doctest::Contains("no VK_NV_cooperative_matrix"), std::invalid_argument);
    });
    MESSAGE("the real fragments are checked on a device with VK_NV_cooperative_matrix (tools/device-check.sh)");
    return;
  }
  check_gpu_path(kernels::nn::Conv3dPath::kCoopMatrix, "nn/conv3d_coopmat", "nn/conv3d_coopmat_f16w");
  check_conv({1, 192, 192, 16, 16, 16, 3, true}, true, 1.0f, 121, 0, ctx, kernels::nn::Conv3dPath::kCoopMatrix);
}

TEST_CASE("conv3d gpu: an fp16 input (a norm's fp16 output) on every path, in one binding and in windows") {
  using S = kernels::nn::Conv3dShape;
  using P = kernels::nn::Conv3dPath;
  gpu::Context& ctx = test::gpu_context();
  std::vector<P> paths = {P::kRegisterTile, P::kSharedTile};
  if (ctx.info().shader_float16) paths.push_back(P::kCoopMatrixEmulated);
  if (ctx.info().cooperative_matrix_nv) paths.push_back(P::kCoopMatrix);
  const uint64_t per_channel = 5 * 6 * 7 * 4;  // fp32 output bytes per channel plane
  const uint64_t align = std::max<uint64_t>(4, ctx.info().min_storage_buffer_offset_alignment);
  for (const P path : paths) {
    check_conv(S{2, 3, 5, 5, 4, 7, 3, false, true}, true, 1.0f, 131, 0, ctx, path);
    check_conv(S{1, 16, 70, 9, 3, 5, 3, true, true}, true, 1.0f, 132, 0, ctx, path);  // 2 channel blocks, fp16 weights
    check_conv(S{1, 7, 9, 3, 5, 2, 1, true, true}, true, 1.0f, 133, 0, ctx, path);    // 1x1 (a linear)
    check_conv(S{1, 8, 16, 9, 3, 33, 3, false, true}, true, 3e4f, 134, 0, ctx, path);  // large activations
    // Windows: 9 input channels of 2-byte elements a window (3,780 bytes: texel offsets off the alignment)
    // and 8-channel output blocks; batch 2.
    check_conv(S{2, 19, 21, 5, 6, 7, 3, true, true}, true, 1.0f, 135, per_channel * 9 + align, ctx, path);
  }
}

TEST_CASE("conv3d gpu: the default path per device and precision") {
  gpu::DeviceInfo cpu, gpu_nv, gpu_other;
  cpu.type = VK_PHYSICAL_DEVICE_TYPE_CPU;
  gpu_nv.type = gpu_other.type = VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU;
  gpu_nv.cooperative_matrix_nv = true;
  gpu_nv.subgroup_size = 32;
  gpu_other.subgroup_size = 64;
  using P = kernels::nn::Conv3dPath;
  CHECK(kernels::nn::default_conv3d_path(cpu, true) == P::kRegisterTile);
  CHECK(kernels::nn::default_conv3d_path(gpu_nv, false) == P::kSharedTile);  // fp32 weights: fp32 FMA
  CHECK(kernels::nn::default_conv3d_path(gpu_nv, true) == P::kCoopMatrix);
  CHECK(kernels::nn::default_conv3d_path(gpu_other, true) == P::kSharedTile);
}

TEST_CASE("conv3d gpu: fp16 weight storage equals the fp32 kernel on fp16-rounded weights") {
  check_conv({2, 3, 5, 5, 4, 7, 3, true}, true, 1.0f, 12);
  check_conv({1, 16, 32, 8, 16, 24, 3, true}, true, 1.0f, 22);
  check_conv({1, 7, 9, 3, 5, 2, 1, true}, true, 1.0f, 32);
  check_conv({1, 20, 24, 6, 5, 7, 3, true}, true, 1.0f, 42, 16384);  // channel windows
  CHECK(kernels::nn::pack_conv3d_weights_f16({1.0f, 65504.0f, 1e-8f, -2.5f}, 4, 1, 1) ==
        std::vector<uint16_t>{0x3C00, 0x7BFF, 0x0000, 0xC100, 0, 0, 0, 0});
}

TEST_CASE("conv3d gpu: tensors larger than one binding run as channel windows and accumulate") {
  // Binding limit pretended small: x (2 x 19 channels) and y (2 x 21) both exceed it; each window holds
  // 9 input channels or one 8-channel output block, bound at offsets that are not multiples of the alignment.
  const uint64_t per_channel = 5 * 6 * 7 * 4;
  const uint64_t align = std::max<uint64_t>(4, test::gpu_context().info().min_storage_buffer_offset_alignment);
  check_conv({2, 19, 21, 5, 6, 7, 3}, true, 1.0f, 61, per_channel * 9 + align);
  check_conv({1, 10, 17, 5, 6, 7, 1}, false, 1.0f, 71, per_channel * 8 + align);
  // Not even one 8-channel output block fits: a clear error.
  gpu::Context& ctx = test::gpu_context();
  gpu::Buffer big(ctx, per_channel * 64, gpu::MemoryUsage::DeviceLocal, "big");
  kernels::nn::Conv3d conv(ctx);
  conv.set_max_binding_bytes(per_channel * 4);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(conv.record(cmd, {1, 16, 16, 5, 6, 7, 1}, big, big, nullptr, big),
                         doctest::Contains("8 channels of 210 voxels exceed one storage binding"), std::invalid_argument);
  });
}

TEST_CASE("conv3d gpu: weights, input and output over a forced 16 KiB binding") {
  // The packed weights of 19 input channels at 21 outputs (2,592 B a channel, 1,296 in fp16) are
  // bound 6 (12) input channels a window, with the feature windows of the same binding.
  gpu::Context& capped = test::capped_gpu_context(16u << 10);
  check_conv({2, 19, 21, 5, 6, 7, 3}, true, 1.0f, 81, 0, capped);
  check_conv({1, 19, 21, 5, 6, 7, 3, true}, true, 1.0f, 82, 0, capped);
  check_conv({1, 40, 9, 4, 3, 5, 1}, false, 1.0f, 83, 0, capped);  // 1x1: 96 B a channel, one window
  // One input channel's weights at 4,096 outputs (27 x 1,024 vec4s = 442 KB) cannot be windowed: named.
  kernels::nn::Conv3d conv(capped);
  gpu::Buffer big(capped, 27u * 1024 * 16 * 2, gpu::MemoryUsage::DeviceLocal, "big");
  capped.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(conv.record(cmd, {1, 2, 4096, 1, 1, 1, 3}, big, big, nullptr, big),
                         doctest::Contains("use fewer output channels"), std::invalid_argument);
  });
}

TEST_CASE("conv3d gpu: weight packing and argument errors") {
  // [Co=2, Ci=1, 1] -> [1][8] with zeros past Co.
  const std::vector<float> p = kernels::nn::pack_conv3d_weights({5.f, 7.f}, 2, 1, 1);
  CHECK(p == std::vector<float>{5.f, 7.f, 0.f, 0.f, 0.f, 0.f, 0.f, 0.f});
  CHECK_THROWS_AS(kernels::nn::pack_conv3d_weights({1.f}, 2, 1, 1), std::invalid_argument);
  gpu::Context& ctx = test::gpu_context();
  gpu::Buffer small(ctx, 16, gpu::MemoryUsage::DeviceLocal, "small");
  kernels::nn::Conv3d conv(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(conv.record(cmd, {1, 2, 2, 4, 4, 4, 3}, small, small, nullptr, small),
                         doctest::Contains("conv3d: input buffer holds 16 bytes"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(conv.record(cmd, {1, 2, 2, 4, 4, 4, 5}, small, small, nullptr, small),
                         doctest::Contains("kernel 5"), std::invalid_argument);
  });
}

TEST_CASE("conv3d gpu: a 1x1 convolution whose input and output both exceed one storage binding") {
  // 130 channels of 64^3 voxels = 136 MB each way, over lavapipe's 128 MiB binding: the real windows.
  gpu::Context& ctx = test::gpu_context();
  const uint32_t C = 130, N = 64;
  const uint64_t S = uint64_t{N} * N * N;
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<float> x(C * S), w(size_t{C} * C), b(C);
  for (float& v : x) v = u(rng);
  for (float& v : w) v = u(rng) * 0.1f;
  for (float& v : b) v = u(rng);
  MESSAGE("conv3d windows: tensors of " << C * S * 4 / 1000000 << " MB, binding limit "
                                        << ctx.info().max_storage_buffer_range / 1000000 << " MB");
  gpu::Buffer xb = gpu::upload_vector(ctx, x, "big-x");
  gpu::Buffer wb = gpu::upload_vector(ctx, kernels::nn::pack_conv3d_weights(w, C, C, 1), "big-w");
  gpu::Buffer bb = gpu::upload_vector(ctx, b, "big-b");
  gpu::Buffer yb(ctx, C * S * 4, gpu::MemoryUsage::DeviceLocal, "big-y");
  kernels::nn::Conv3d conv(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, {1, C, C, N, N, N, 1}, xb, wb, &bb, yb); });
  const std::vector<float> y = gpu::download_vector<float>(ctx, yb, C * S);
  // 4,000 sampled outputs against the definition (double sums).
  std::uniform_int_distribution<uint64_t> pick_v(0, S - 1);
  std::uniform_int_distribution<uint32_t> pick_c(0, C - 1);
  size_t bad = 0;
  for (int i = 0; i < 4000; ++i) {
    const uint64_t v = i < 2 ? (i == 0 ? 0 : S - 1) : pick_v(rng);
    const uint32_t co = i < 2 ? (i == 0 ? 0 : C - 1) : pick_c(rng);
    double want = static_cast<double>(b[co]), bound = 0.0;
    for (uint32_t ci = 0; ci < C; ++ci) {
      const double t = static_cast<double>(w[size_t{co} * C + ci]) * static_cast<double>(x[ci * S + v]);
      want += t;
      bound += std::abs(t);
    }
    const double err = std::abs(static_cast<double>(y[co * S + v]) - want);
    if (!(err <= 1e-6 + C * std::ldexp(1.0, -23) * bound) && ++bad <= 5)
      MESSAGE("voxel " << v << " channel " << co << ": got " << y[co * S + v] << " want " << want);
  }
  CHECK(bad == 0);
}

// The CPU reference on cases with known answers.
namespace {


nn::CpuTensor cpu_random_tensor(std::vector<int64_t> shape, uint32_t seed, float scale = 1.0f) {
  nn::CpuTensor t(std::move(shape));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-scale, scale);
  for (float& v : t.data) v = u(rng);
  return t;
}

}  // namespace

TEST_CASE("nn cpu: conv3d equals the per-output definition (odd sizes, padding, stride 2, 1x1)") {
  const nn::CpuTensor x = cpu_random_tensor({2, 3, 5, 4, 7}, 1);
  const nn::CpuTensor w = cpu_random_tensor({4, 3, 3, 3, 3}, 2);
  const nn::CpuTensor b = cpu_random_tensor({4}, 3);
  for (const int stride : {1, 2}) {
    const nn::CpuTensor y = nn::cpu::conv3d(x, w, &b, stride, 1);
    const int64_t OX = (5 + 2 - 3) / stride + 1, OY = (4 + 2 - 3) / stride + 1, OZ = (7 + 2 - 3) / stride + 1;
    REQUIRE(y.shape == std::vector<int64_t>{2, 4, OX, OY, OZ});
    double worst = 0.0;
    for (int64_t n = 0; n < 2; ++n)
      for (int64_t o = 0; o < 4; ++o)
        for (int64_t i = 0; i < OX; ++i)
          for (int64_t j = 0; j < OY; ++j)
            for (int64_t k = 0; k < OZ; ++k) {
              long double s = b.data[static_cast<size_t>(o)];
              for (int64_t c = 0; c < 3; ++c)
                for (int64_t a = 0; a < 3; ++a)
                  for (int64_t e = 0; e < 3; ++e)
                    for (int64_t f = 0; f < 3; ++f) {
                      const int64_t xi = i * stride - 1 + a, yj = j * stride - 1 + e, zk = k * stride - 1 + f;
                      if (xi < 0 || xi >= 5 || yj < 0 || yj >= 4 || zk < 0 || zk >= 7) continue;
                      s += static_cast<long double>(w.data[static_cast<size_t>((((o * 3 + c) * 3 + a) * 3 + e) * 3 + f)]) *
                           x.data[static_cast<size_t>((((n * 3 + c) * 5 + xi) * 4 + yj) * 7 + zk)];
                    }
              const float got = y.data[static_cast<size_t>((((n * 4 + o) * OX + i) * OY + j) * OZ + k)];
              worst = std::max(worst, std::abs(static_cast<double>(got) - static_cast<double>(s)));
            }
    CHECK(worst < 1e-6);
  }
  // 1x1: the same as a channel matrix product.
  const nn::CpuTensor w1 = cpu_random_tensor({2, 3, 1, 1, 1}, 4);
  const nn::CpuTensor y1 = nn::cpu::conv3d(x, w1, nullptr, 1, 0);
  const size_t S = 5 * 4 * 7;
  const float want = w1.data[3] * x.data[S * 3 + 10] + w1.data[4] * x.data[S * 4 + 10] + w1.data[5] * x.data[S * 5 + 10];
  CHECK(y1.data[S * 3 + 10] == doctest::Approx(want).epsilon(1e-6));
  CHECK_THROWS_AS(nn::cpu::conv3d(x, cpu_random_tensor({4, 2, 3, 3, 3}, 5), nullptr), std::invalid_argument);
}
