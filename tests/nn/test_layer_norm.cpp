// LayerNorm over channels on the GPU (kernels/nn/layer_norm.h,
// shaders/nn/layer_norm.comp) against the
// CPU reference (nn::cpu::layer_norm over the last axis of the transposed
// tensor): batch 2, odd token counts, 64 and 7 channels, a large common offset
// and a constant token (exactly the bias); the fp16 output (layer_norm_f16out.comp)
// against the reference rounded to fp16. Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "half_values.h"
#include "kernels/nn/layer_norm.h"

#include <random>

using namespace icube;

namespace {

void check_ln(uint32_t batch, uint32_t channels, uint32_t tokens, float offset, uint32_t seed, double tol,
              bool f16_output = false) {
  CAPTURE(channels);
  CAPTURE(tokens);
  gpu::Context& ctx = test::gpu_context();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  nn::CpuTensor x({batch, channels, tokens});  // channels-first
  for (float& v : x.data) v = offset + u(rng);
  for (uint32_t c = 0; c < channels; ++c) x.data[c * tokens] = 3.5f;  // token 0 of batch 0 constant
  nn::CpuTensor w({channels}), b({channels});
  for (float& v : w.data) v = 1.0f + 0.2f * u(rng);
  for (float& v : b.data) v = 0.3f * u(rng);
  // Reference on [batch, tokens, channels].
  nn::CpuTensor xt({batch, tokens, channels});
  for (uint32_t n = 0; n < batch; ++n)
    for (uint32_t c = 0; c < channels; ++c)
      for (uint32_t t = 0; t < tokens; ++t) xt.data[(n * tokens + t) * channels + c] = x.data[(n * channels + c) * tokens + t];
  const nn::CpuTensor yt = nn::cpu::layer_norm(xt, w, b, 1e-5);
  std::vector<float> want(x.data.size());
  for (uint32_t n = 0; n < batch; ++n)
    for (uint32_t c = 0; c < channels; ++c)
      for (uint32_t t = 0; t < tokens; ++t) want[(n * channels + c) * tokens + t] = yt.data[(n * tokens + t) * channels + c];
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data), wb = gpu::upload_vector(ctx, w.data), bb = gpu::upload_vector(ctx, b.data);
  gpu::Buffer yb(ctx, x.data.size() * (f16_output ? 2 : 4));
  kernels::nn::LayerNorm ln(ctx);
  ctx.submit_and_wait(
      [&](gpu::CommandList& cmd) { ln.record(cmd, {batch, channels, tokens, 1e-5f, f16_output}, xb, wb, bb, yb); });
  const std::vector<float> got =
      f16_output ? test::download_halves(ctx, yb, x.data.size()) : gpu::download_vector<float>(ctx, yb, x.data.size());
  if (f16_output)
    CHECK(test::half_store_matches(got, want, tol, 0.01, "layer_norm fp16"));
  else
    CHECK(test::allclose(got, want, tol, tol, "layer_norm"));
  const std::vector<float> bias = f16_output ? test::rounded_to_half(b.data) : b.data;
  for (uint32_t c = 0; c < channels; ++c) CHECK(got[c * tokens] == bias[c]);  // the constant token
}

}  // namespace

TEST_CASE("layer_norm gpu: over channels of channels-first tokens, against the CPU reference") {
  check_ln(2, 64, 6, 0.0f, 1, 1e-5);
  check_ln(1, 7, 131, 0.0f, 2, 1e-5);
  check_ln(1, 64, 65, 100.0f, 3, 1e-4);  // offset 100: fp32 steps of 2^-17 in x, Welford keeps the rest
}

TEST_CASE("layer_norm gpu: an fp16 output (the next linear's operand) is the reference rounded to fp16") {
  check_ln(2, 64, 6, 0.0f, 4, 1e-5, true);
  check_ln(1, 7, 131, 0.0f, 5, 1e-5, true);
}
