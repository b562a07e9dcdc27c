// x-unet's Downsample (space-to-depth 2x2 + 1x1 conv) as one 2x2 stride-2
// conv2d (kernels/nn/space_to_depth.h): the CPU rearrangement on a hand
// example; the equivalence conv2d(x, w2, stride 2) = conv2d(space_to_depth(x),
// w1) on the CPU references; the GPU conv2d with the permuted weights against
// the CPU space-to-depth + 1x1 conv (batch 3, odd channel counts, large
// activations, windows over a capped binding) with float32 accumulation's
// bound 1e-6 + 4C 2^-23 sum |w x|; then gsm_small's pix.unet.downs.<s>.3 from
// the reference inputs. Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/space_to_depth.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

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

// The GPU Downsample of x [B, C, H, W] with the 1x1 weight w1 [Co, 4C] and bias.
std::vector<float> gpu_downsample(const nn::CpuTensor& x, const nn::CpuTensor& w1, const nn::CpuTensor* bias,
                                  uint64_t max_binding_bytes = 0) {
  gpu::Context& ctx = test::gpu_context();
  const uint32_t B = static_cast<uint32_t>(x.dim(0)), C = static_cast<uint32_t>(x.dim(1));
  const uint32_t Co = static_cast<uint32_t>(w1.dim(0));
  REQUIRE(w1.numel() == int64_t{Co} * 4 * C);
  const kernels::nn::Conv2dShape s =
      kernels::nn::space_to_depth_conv_shape(B, C, Co, static_cast<uint32_t>(x.dim(2)), static_cast<uint32_t>(x.dim(3)));
  const std::vector<float> w2 = kernels::nn::space_to_depth_conv_weights(w1.data, Co, C);
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data, "s2d-x");
  gpu::Buffer wb = gpu::upload_vector(ctx, kernels::nn::pack_conv2d_weights(w2, Co, C, 2, 2), "s2d-w");
  gpu::Buffer bb = gpu::upload_vector(ctx, bias ? bias->data : std::vector<float>{0.0f}, "s2d-b");
  const size_t n = size_t{B} * Co * s.out_height() * s.out_width();
  gpu::Buffer yb(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "s2d-y");
  kernels::nn::Conv2d conv(ctx);
  conv.set_max_binding_bytes(max_binding_bytes);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, xb, wb, bias ? &bb : nullptr, yb); });
  return gpu::download_vector<float>(ctx, yb, n);
}

void check_downsample(int64_t B, int64_t C, int64_t Co, int64_t H, int64_t W, bool with_bias, float x_scale, uint32_t seed,
                      uint64_t max_binding_bytes = 0) {
  CAPTURE(B);
  CAPTURE(C);
  CAPTURE(Co);
  CAPTURE(H);
  CAPTURE(W);
  CAPTURE(max_binding_bytes);
  const nn::CpuTensor x = random_tensor({B, C, H, W}, seed, x_scale);
  const nn::CpuTensor w1 = random_tensor({Co, 4 * C, 1, 1}, seed + 1, 0.5f);
  const nn::CpuTensor b = random_tensor({Co}, seed + 2, 1.0f);
  const nn::CpuTensor s2d = nn::cpu::space_to_depth(x);
  const nn::CpuTensor want = nn::cpu::conv2d(s2d, w1, with_bias ? &b : nullptr);
  const nn::CpuTensor bound = nn::cpu::conv2d(abs_of(s2d), abs_of(w1), nullptr);
  const std::vector<float> got = gpu_downsample(x, w1, with_bias ? &b : nullptr, max_binding_bytes);
  REQUIRE(got.size() == want.data.size());
  size_t bad = 0;
  double worst = 0.0;
  for (size_t i = 0; i < got.size(); ++i) {
    const double tol = 1e-6 + 4.0 * static_cast<double>(C) * std::ldexp(1.0, -23) * static_cast<double>(bound.data[i]);
    const double err = std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i]));
    worst = std::max(worst, err / tol);
    if (!(err <= tol) && ++bad <= 5)
      std::printf("  downsample mismatch at %zu: got %.9g want %.9g (tol %.3g)\n", i, static_cast<double>(got[i]),
                  static_cast<double>(want.data[i]), tol);
  }
  std::printf("  downsample %lldx%lldx%lldx%lld -> %lld cap %llu: worst error %.3g of the bound\n", static_cast<long long>(B),
              static_cast<long long>(C), static_cast<long long>(H), static_cast<long long>(W), static_cast<long long>(Co),
              static_cast<unsigned long long>(max_binding_bytes), worst);
  CHECK(bad == 0);
}

}  // namespace

TEST_CASE("space_to_depth reference: x-unet's channel order c * 4 + dy * 2 + dx") {
  // One channel, 2 x 4: the four 2 x 2 phases become channels (0,0), (0,1), (1,0), (1,1).
  const nn::CpuTensor x({1, 1, 2, 4}, std::vector<float>{0, 1, 2, 3, 4, 5, 6, 7});
  const nn::CpuTensor y = nn::cpu::space_to_depth(x);
  CHECK(y.shape == std::vector<int64_t>{1, 4, 1, 2});
  CHECK(y.data == std::vector<float>{0, 2, 1, 3, 4, 6, 5, 7});
  // Two channels: channel 1's phases follow channel 0's.
  const nn::CpuTensor x2({1, 2, 2, 2}, std::vector<float>{0, 1, 2, 3, 10, 11, 12, 13});
  CHECK(nn::cpu::space_to_depth(x2).data == std::vector<float>{0, 1, 2, 3, 10, 11, 12, 13});
  CHECK_THROWS_AS(nn::cpu::space_to_depth(nn::CpuTensor({1, 1, 3, 4})), std::invalid_argument);
  CHECK_THROWS_AS(kernels::nn::space_to_depth_conv_shape(1, 1, 1, 4, 5), std::invalid_argument);
  // The permutation: w2[o, c, dy, dx] = w1[o, c * 4 + dy * 2 + dx].
  std::vector<float> w1(2 * 3 * 4);
  for (size_t i = 0; i < w1.size(); ++i) w1[i] = static_cast<float>(i);
  const std::vector<float> w2 = kernels::nn::space_to_depth_conv_weights(w1, 2, 3);
  for (int o = 0; o < 2; ++o)
    for (int c = 0; c < 3; ++c)
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx)
          CHECK(w2[static_cast<size_t>(((o * 3 + c) * 2 + dy) * 2 + dx)] == w1[static_cast<size_t>(o * 12 + c * 4 + dy * 2 + dx)]);
  CHECK_THROWS_AS(kernels::nn::space_to_depth_conv_weights(w1, 2, 2), std::invalid_argument);
}

TEST_CASE("space_to_depth reference: space-to-depth + 1x1 conv equals the 2x2 stride-2 conv with permuted weights") {
  const nn::CpuTensor x = random_tensor({2, 5, 6, 10}, 1, 1.0f);
  const nn::CpuTensor w1 = random_tensor({7, 20, 1, 1}, 2, 0.5f);
  const nn::CpuTensor b = random_tensor({7}, 3, 1.0f);
  const nn::CpuTensor want = nn::cpu::conv2d(nn::cpu::space_to_depth(x), w1, &b);
  const nn::CpuTensor w2({7, 5, 2, 2}, kernels::nn::space_to_depth_conv_weights(w1.data, 7, 5));
  const nn::CpuTensor got = nn::cpu::conv2d(x, w2, &b, 2, 0);
  CHECK(got.shape == want.shape);
  CHECK(test::allclose(got.data, want.data, 1e-6, 1e-6, "downsample as a strided conv"));
}

TEST_CASE("space_to_depth gpu: x-unet's Downsample as one conv2d against space-to-depth + 1x1") {
  check_downsample(3, 5, 11, 6, 10, true, 1.0f, 1);   // batch 3, odd channel counts
  check_downsample(1, 8, 8, 48, 80, true, 1.0f, 11);  // gsm_small's first stage
  check_downsample(1, 32, 64, 12, 20, false, 1.0f, 21);
  check_downsample(1, 3, 9, 2, 2, true, 3e4f, 31);    // one output pixel, large activations
  const uint64_t align = std::max<uint64_t>({4, test::gpu_context().info().min_storage_buffer_offset_alignment,
                                             test::gpu_context().info().min_texel_buffer_offset_alignment});
  check_downsample(2, 9, 17, 8, 6, true, 1.0f, 41, 8 * 6 * 4 * 2 + align);  // windows of 2 input, 8 output channels
}

TEST_CASE("space_to_depth gpu: gsm_small's x-unet Downsamples pix.unet.downs.*.3") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  for (int s = 0; s < 4; ++s) {
    const std::string n = "pix.unet.downs." + std::to_string(s);
    const std::string p = "backbone.backbone_2d.net.downs." + std::to_string(s) + ".3.1.";
    nn::CpuTensor x = ref.get(n + ".1.0");  // [1, C, 1, H, W]
    x = nn::CpuTensor({x.dim(0), x.dim(1), x.dim(3), x.dim(4)}, x.data);
    const nn::CpuTensor& w5 = w.at(p + "weight");  // [Co, 4C, 1, 1, 1]
    REQUIRE(w5.dim(1) == 4 * x.dim(1));
    const nn::CpuTensor w1({w5.dim(0), w5.dim(1)}, w5.data);
    const std::vector<float> y = gpu_downsample(x, w1, &w.at(p + "bias"));
    test::check_gsm_tensor(ref, n + ".3", nn::CpuTensor({x.dim(0), w5.dim(0), 1, x.dim(2) / 2, x.dim(3) / 2}, y));
  }
}
