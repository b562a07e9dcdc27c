// Multi-head attention on the GPU (kernels/nn/attention.h: attention.comp and, forced,
// attention_tiled.comp) against the CPU
// reference (nn::cpu::attention on [B, H, N, D]): separate q / k / v and one
// chunked qkv buffer, batch 2, odd token counts, head_dim 8 and 96 (the
// released model's), logits of 1e4 (online softmax stays finite). Validation on.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "kernels/nn/attention.h"

#include <cmath>
#include <optional>
#include <random>
#include <string>

using namespace icube;

namespace {

// [B, H*D, N] (channels-first, starting at channel c0 of a buffer with `ctot` channels) -> [B, H, N, D].
nn::CpuTensor heads_of(const std::vector<float>& x, uint32_t B, uint32_t H, uint32_t D, uint32_t N, uint32_t c0,
                       uint32_t ctot) {
  nn::CpuTensor t({B, H, N, D});
  for (uint32_t b = 0; b < B; ++b)
    for (uint32_t h = 0; h < H; ++h)
      for (uint32_t n = 0; n < N; ++n)
        for (uint32_t d = 0; d < D; ++d)
          t.data[((size_t{b} * H + h) * N + n) * D + d] = x[(size_t{b} * ctot + c0 + h * D + d) * N + n];
  return t;
}

void check_attention(uint32_t B, uint32_t H, uint32_t D, uint32_t N, float scale, bool chunked, uint32_t seed,
                     std::optional<kernels::nn::AttentionPath> path = std::nullopt) {
  CAPTURE(H);
  CAPTURE(D);
  CAPTURE(N);
  CAPTURE(chunked);
  gpu::Context& ctx = test::gpu_context();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-scale, scale);
  const uint32_t C = H * D;
  std::vector<float> qkv(size_t{B} * 3 * C * N);
  for (float& v : qkv) v = u(rng);
  const nn::CpuTensor q = heads_of(qkv, B, H, D, N, 0, 3 * C), k = heads_of(qkv, B, H, D, N, C, 3 * C),
                      v = heads_of(qkv, B, H, D, N, 2 * C, 3 * C);
  const nn::CpuTensor o = nn::cpu::attention(q, k, v);
  std::vector<float> want(size_t{B} * C * N);
  for (uint32_t b = 0; b < B; ++b)
    for (uint32_t h = 0; h < H; ++h)
      for (uint32_t n = 0; n < N; ++n)
        for (uint32_t d = 0; d < D; ++d)
          want[(size_t{b} * C + h * D + d) * N + n] = o.data[((size_t{b} * H + h) * N + n) * D + d];
  gpu::Buffer out(ctx, want.size() * 4);
  kernels::nn::Attention attn(ctx);
  attn.force_path(path);
  const kernels::nn::AttentionShape s{B, H, D, N};
  if (chunked) {
    gpu::Buffer qkvb = gpu::upload_vector(ctx, qkv);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { attn.record_qkv(cmd, s, qkvb, out); });
  } else {
    // Separate channels-first buffers.
    std::vector<float> qs, ks, vs;
    for (uint32_t b = 0; b < B; ++b)
      for (uint32_t part = 0; part < 3; ++part) {
        std::vector<float>& dst = part == 0 ? qs : part == 1 ? ks : vs;
        dst.insert(dst.end(), qkv.begin() + (size_t{b} * 3 + part) * C * N, qkv.begin() + (size_t{b} * 3 + part + 1) * C * N);
      }
    gpu::Buffer qb = gpu::upload_vector(ctx, qs), kb = gpu::upload_vector(ctx, ks), vb = gpu::upload_vector(ctx, vs);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { attn.record(cmd, s, qb, kb, vb, out); });
  }
  const std::vector<float> got = gpu::download_vector<float>(ctx, out, want.size());
  bool finite = true;
  for (float f : got) finite = finite && std::isfinite(f);
  CHECK(finite);
  CHECK(test::allclose(got, want, 2e-5 * static_cast<double>(scale), 2e-5, "attention"));
}

}  // namespace

TEST_CASE("attention gpu: against the CPU reference, separate and chunked qkv, huge logits") {
  check_attention(2, 3, 8, 33, 1.0f, false, 1);
  check_attention(1, 8, 8, 6, 1.0f, true, 2);    // unet_small's level-3 blocks
  check_attention(1, 2, 96, 17, 1.0f, true, 3);  // the released model's head size
  // Past lavapipe's 65,535 loop iterations per invocation for a one-key-per-iteration loop
  // (512 x (2 x 96 + 1) and 5,001 x (2 x 8 + 1)): keys 4 and head dims 8 per iteration keep under it.
  check_attention(1, 2, 96, 512, 1.0f, false, 5);
  check_attention(1, 1, 8, 5001, 1.0f, true, 6);
  check_attention(1, 1, 100, 37, 1.0f, false, 7);  // head_dim not a multiple of 8
  check_attention(1, 2, 4, 9, 200.0f, false, 4); // logits up to ~4e4: one key takes all the weight
  kernels::nn::Attention attn(test::gpu_context());
  gpu::Buffer tiny(test::gpu_context(), 64);
  test::gpu_context().submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(attn.record(cmd, {1, 1, 200, 1}, tiny, tiny, tiny, tiny), doctest::Contains("head_dim 200"),
                         std::invalid_argument);
    if (test::gpu_context().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU)
      CHECK_THROWS_WITH_AS(attn.record(cmd, {1, 1, 96, 20000}, tiny, tiny, tiny, tiny),
                           doctest::Contains("over a CPU device's budget"), std::invalid_argument);
  });
}

TEST_CASE("attention gpu: attention_tiled (shared-memory key blocks, a quad per query) against the CPU reference") {
  CHECK(std::string(kernels::nn::Attention::shader_name(kernels::nn::AttentionPath::kTiled)) == "nn/attention_tiled");
  // Forced on the test device; token counts across the 64-query and 32-key block edges, head_dim 8, 96
  // (the released model's), 100 and 128, batch 2, chunked qkv and huge logits.
  using P = kernels::nn::AttentionPath;
  check_attention(2, 3, 8, 33, 1.0f, false, 11, P::kTiled);
  check_attention(1, 8, 8, 6, 1.0f, true, 12, P::kTiled);
  check_attention(1, 2, 96, 17, 1.0f, true, 13, P::kTiled);
  check_attention(1, 2, 96, 130, 1.0f, false, 14, P::kTiled);
  check_attention(2, 1, 128, 65, 1.0f, true, 15, P::kTiled);
  check_attention(1, 1, 100, 37, 1.0f, false, 16, P::kTiled);
  check_attention(1, 2, 4, 9, 200.0f, false, 17, P::kTiled);
  check_attention(1, 1, 8, 1, 1.0f, false, 18, P::kTiled);  // one token
  kernels::nn::Attention attn(test::gpu_context());
  attn.force_path(P::kTiled);
  gpu::Buffer tiny(test::gpu_context(), 64);
  if (test::gpu_context().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU)
    test::gpu_context().submit_and_wait([&](gpu::CommandList& cmd) {
      CHECK_THROWS_WITH_AS(attn.record(cmd, {1, 1, 96, 4096}, tiny, tiny, tiny, tiny),
                           doctest::Contains("over a CPU device's budget"), std::invalid_argument);
    });
}

TEST_CASE("nn cpu: attention with huge logits is a stable softmax; uniform keys average the values") {
  nn::CpuTensor q({1, 1, 2, 2}, std::vector<float>{1e4f, 0.f, 0.f, 0.f});
  nn::CpuTensor k({1, 1, 2, 2}, std::vector<float>{1e4f, 0.f, -1e4f, 0.f});
  nn::CpuTensor v({1, 1, 2, 2}, std::vector<float>{1.f, 2.f, 3.f, 4.f});
  const nn::CpuTensor o = nn::cpu::attention(q, k, v);
  CHECK(o.data[0] == 1.0f);  // all weight on key 0
  CHECK(o.data[1] == 2.0f);
  CHECK(o.data[2] == 2.0f);  // query 1 is zero: equal weights, the mean of the values
  CHECK(o.data[3] == 3.0f);
}
