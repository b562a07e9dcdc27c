// GroupNorm on the GPU (kernels/nn/group_norm.h: shaders/nn/group_norm_partials.comp,
// group_norm_stats.comp and group_norm_apply.comp, all three in every case) against the CPU reference
// (nn::cpu::group_norm, then scale_shift and SiLU): odd spatial sizes, batch 2,
// 32 groups of 2 channels and 8 groups of 3, fused modulation + SiLU, a
// constant input (normalises to exactly the bias), a large common offset
// (1e4 + noise: Welford must not cancel), eps 1e-6 as SpatialTransformer's
// norm; the fp16 output (group_norm_apply_f16out.comp) against the
// reference rounded to fp16, in one binding, in windows and in spans.
// Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "half_values.h"
#include "kernels/nn/group_norm.h"
#include "kernels/nn/elementwise.h"

#include <random>

using namespace icube;

namespace {

void check_gn(const kernels::nn::GroupNormShape& s, float offset, float scale, uint32_t seed, double tol,
              uint64_t max_binding_bytes = 0) {
  CAPTURE(s.channels);
  CAPTURE(s.groups);
  CAPTURE(s.spatial);
  CAPTURE(offset);
  gpu::Context& ctx = test::gpu_context();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  nn::CpuTensor x({s.batch, s.channels, static_cast<int64_t>(s.spatial)});
  for (float& v : x.data) v = offset + scale * u(rng);
  nn::CpuTensor w({s.channels}), b({s.channels}), mod({s.batch, 2 * static_cast<int64_t>(s.channels)});
  for (float& v : w.data) v = 1.0f + 0.3f * u(rng);
  for (float& v : b.data) v = 0.5f * u(rng);
  for (float& v : mod.data) v = 0.5f * u(rng);
  nn::CpuTensor want = nn::cpu::group_norm(x, static_cast<int>(s.groups), w, b, static_cast<double>(s.eps));
  if (s.modulate) want = nn::cpu::scale_shift(std::move(want), mod);
  if (s.silu) want = nn::cpu::silu(std::move(want));

  gpu::Buffer xb = gpu::upload_vector(ctx, x.data, "gn-x");
  gpu::Buffer wb = gpu::upload_vector(ctx, w.data, "gn-w");
  gpu::Buffer bb = gpu::upload_vector(ctx, b.data, "gn-b");
  gpu::Buffer mb = gpu::upload_vector(ctx, mod.data, "gn-mod");
  gpu::Buffer scratch(ctx, kernels::nn::GroupNorm::scratch_bytes(s), gpu::MemoryUsage::DeviceLocal, "gn-scratch");
  gpu::Buffer yb(ctx, x.data.size() * (s.f16_output ? 2 : 4), gpu::MemoryUsage::DeviceLocal, "gn-y");
  kernels::nn::GroupNorm gn(ctx);
  gn.set_max_binding_bytes(max_binding_bytes);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { gn.record(cmd, s, xb, wb, bb, s.modulate ? &mb : nullptr, scratch, yb); });
  if (s.f16_output) {
    CHECK(test::half_store_matches(test::download_halves(ctx, yb, x.data.size()), want.data, tol, 0.01, "group_norm fp16"));
    return;
  }
  const std::vector<float> got = gpu::download_vector<float>(ctx, yb, x.data.size());
  CHECK(test::allclose(got, want.data, tol, tol, "group_norm"));
}

}  // namespace

TEST_CASE("group_norm gpu: against the CPU reference, plain, modulated, with SiLU, constant and offset inputs") {
  check_gn({2, 64, 32, 5 * 7 * 3, 1e-5f, false, false}, 0.0f, 1.0f, 1, 2e-5);
  check_gn({1, 24, 8, 8 * 16 * 24, 1e-5f, true, true}, 0.0f, 3.0f, 2, 2e-5);    // ResBlock out_layers, fused
  check_gn({2, 64, 32, 1, 1e-6f, false, true}, 0.5f, 1.0f, 3, 2e-5);            // a single voxel: 2 values a group
  // Offset 1e4: x itself carries fp32 steps of 2^-10 ~ 1e-3 and the mean one rounding of that size;
  // divided by the group's std (~0.58) that bounds the error near 1e-3 (a naive sum of squares fails outright).
  check_gn({1, 32, 32, 4 * 4 * 4, 1e-5f, false, false}, 1e4f, 1.0f, 4, 2e-3);
  // Constant input: every deviation is exactly 0, so y is exactly the bias.
  check_gn({1, 32, 32, 9 * 9 * 9, 1e-5f, false, false}, 7.25f, 0.0f, 5, 0.0);
  check_gn({1, 32, 32, 9 * 9 * 9, 1e-5f, true, true}, 7.25f, 0.0f, 6, 1e-6);  // then modulated (fma rounding)
}

TEST_CASE("group_norm gpu: tensors beyond one binding run in windows of whole groups (batch 2, modulated)") {
  // As if one binding held 4 KiB: groups of 3 channels x 105 voxels (1,260 B), 3 groups a window,
  // windows starting off the binding alignment, the modulation rows of both batch elements.
  check_gn({2, 96, 32, 5 * 7 * 3, 1e-5f, true, true}, 0.0f, 2.0f, 7, 2e-5, 4096);
  check_gn({1, 64, 32, 9 * 9 * 9, 1e-5f, false, false}, 3.0f, 1.0f, 8, 2e-5, 16384);
}

TEST_CASE("group_norm gpu: one group larger than a binding runs in spans (continued partials, then the statistics)") {
  // As if one binding held 256 B (a few dozen elements): groups of 2 x 729 = 1,458 elements in spans
  // that start off the chunk stride (22 partials a group), so each span continues every chunk's triple.
  check_gn({1, 64, 32, 9 * 9 * 9, 1e-5f, false, false}, 0.0f, 1.0f, 9, 2e-5, 256);
  check_gn({2, 48, 8, 5 * 7 * 3, 1e-5f, true, true}, 0.0f, 2.0f, 10, 2e-5, 512);  // modulated, batch 2
  // The shift (the group's first element) travels with the partials: a large offset stays exact.
  check_gn({1, 32, 32, 4 * 4 * 4, 1e-5f, false, false}, 1e4f, 1.0f, 11, 2e-3, 128);
  check_gn({1, 32, 32, 9 * 9 * 9, 1e-5f, false, false}, 7.25f, 0.0f, 12, 0.0, 256);  // constant: exactly the bias
}

TEST_CASE("group_norm gpu: an fp16 output (the next convolution's operand) is the reference rounded to fp16") {
  // Plain, and the ResBlock's modulated SiLU; then windows of whole groups (4 KiB bindings: the fp16 output
  // windows are half as long in bytes and start at 2-byte offsets) and one group in spans (256 B).
  check_gn({2, 64, 32, 5 * 7 * 3, 1e-5f, false, false, true}, 0.0f, 1.0f, 21, 2e-5);
  check_gn({1, 24, 8, 8 * 16 * 24, 1e-5f, true, true, true}, 0.0f, 3.0f, 22, 2e-5);
  check_gn({2, 96, 32, 5 * 7 * 3, 1e-5f, true, true, true}, 0.0f, 2.0f, 23, 2e-5, 4096);
  check_gn({1, 64, 32, 9 * 9 * 9, 1e-5f, false, false, true}, 0.0f, 1.0f, 24, 2e-5, 256);
  // A constant input normalises to exactly the bias, and its fp16 rounding exactly.
  check_gn({1, 32, 32, 9 * 9 * 9, 1e-5f, false, false, true}, 7.25f, 0.0f, 25, 0.0);
}

TEST_CASE("nn cpu: GroupNorm of a constant is its bias; statistics per group; huge values stay finite") {
  nn::CpuTensor x({1, 64, 2, 3, 1}, 1e6f);
  nn::CpuTensor w({64}, 3.0f), b({64}, 0.0f);
  for (int c = 0; c < 64; ++c) b.data[static_cast<size_t>(c)] = static_cast<float>(c);
  const nn::CpuTensor y = nn::cpu::group_norm(x, 32, w, b, 1e-5);
  for (int c = 0; c < 64; ++c) CHECK(y.data[static_cast<size_t>(c * 6)] == static_cast<float>(c));
  // A ramp within one group of two channels: mean and biased variance over 12 values.
  nn::CpuTensor r({1, 2, 2, 3, 1});
  for (int i = 0; i < 12; ++i) r.data[static_cast<size_t>(i)] = static_cast<float>(i);
  const nn::CpuTensor yr = nn::cpu::group_norm(r, 1, nn::CpuTensor({2}, 1.0f), nn::CpuTensor({2}, 0.0f), 0.0);
  const double sd = std::sqrt((144.0 - 1.0) / 12.0);  // variance of 0..11
  CHECK(yr.data[0] == doctest::Approx(-5.5 / sd).epsilon(1e-6));
  CHECK(yr.data[11] == doctest::Approx(5.5 / sd).epsilon(1e-6));
  CHECK_THROWS_AS(nn::cpu::group_norm(r, 3, nn::CpuTensor({2}), nn::CpuTensor({2}), 1e-5), std::invalid_argument);
}
