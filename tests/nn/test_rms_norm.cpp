// x-unet's RMSNorm on the GPU (kernels/nn/rms_norm.h, shaders/nn/rms_norm.comp)
// against the CPU reference (nn::cpu::rms_norm, with nn::cpu::silu for the
// fused form): batch 3, odd images, 1 / 5 / 64 / 333 channels, with and
// without SiLU, pixels of extreme scales (1e-20: the eps clamp and the
// underflow path; 1e-14; 3e4; 1e25: the overflow path; all zero), in place,
// in windows (whole batch elements; pixel ranges of one element), at the
// 20,000-channel loop budget, and the refusals. The bound per element is
// 1e-6 + 2^-23 (C + 16 + 2 |z|) |z| for the normalised value z (the float32
// sum of squares, the scaling, and SiLU's exp). Then the official gsm_small
// case: x-unet's ResnetBlocks downs.<s>.0 / .1.0 (conv -> RMSNorm + SiLU, twice,
// plus the input) on the GPU from the reference inputs. Validation layer on.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/elementwise.h"
#include "kernels/nn/rms_norm.h"
#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

using namespace icube;

namespace {

// [B, C, H, W] of N(0, 1) values, each pixel scaled by one of `scales` (cycling over the pixels).
nn::CpuTensor random_pixels(int64_t B, int64_t C, int64_t H, int64_t W, uint32_t seed, const std::vector<float>& scales) {
  nn::CpuTensor t({B, C, H, W});
  std::mt19937 rng(seed);
  std::normal_distribution<float> nd(0.0f, 1.0f);
  for (float& v : t.data) v = nd(rng);
  const int64_t S = H * W;
  for (int64_t b = 0; b < B; ++b)
    for (int64_t s = 0; s < S; ++s) {
      const float k = scales[static_cast<size_t>((b * S + s) % static_cast<int64_t>(scales.size()))];
      for (int64_t c = 0; c < C; ++c) t.data[static_cast<size_t>((b * C + c) * S + s)] *= k;
    }
  return t;
}

std::vector<float> run_gpu(const kernels::nn::RmsNormShape& s, const nn::CpuTensor& x, const nn::CpuTensor& gamma,
                           uint64_t max_binding_bytes, bool in_place) {
  gpu::Context& ctx = test::gpu_context();
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data, "rms-x");
  gpu::Buffer gb = gpu::upload_vector(ctx, gamma.data, "rms-gamma");
  gpu::Buffer yb(ctx, x.data.size() * 4, gpu::MemoryUsage::DeviceLocal, "rms-y");
  kernels::nn::RmsNorm norm(ctx);
  norm.set_max_binding_bytes(max_binding_bytes);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { norm.record(cmd, s, xb, gb, in_place ? xb : yb); });
  return gpu::download_vector<float>(ctx, in_place ? xb : yb, x.data.size());
}

void check_rms_norm(int64_t B, int64_t C, int64_t H, int64_t W, bool silu, const std::vector<float>& scales, uint32_t seed,
                    uint64_t max_binding_bytes = 0, bool in_place = false) {
  CAPTURE(B);
  CAPTURE(C);
  CAPTURE(H);
  CAPTURE(W);
  CAPTURE(silu);
  CAPTURE(max_binding_bytes);
  CAPTURE(in_place);
  const nn::CpuTensor x = random_pixels(B, C, H, W, seed, scales);
  nn::CpuTensor gamma({C});
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  for (float& g : gamma.data) g = u(rng);
  const nn::CpuTensor z = nn::cpu::rms_norm(x, gamma);
  const nn::CpuTensor want = silu ? nn::cpu::silu(z) : z;
  kernels::nn::RmsNormShape s;
  s.batch = static_cast<uint32_t>(B);
  s.channels = static_cast<uint32_t>(C);
  s.plane = static_cast<uint64_t>(H * W);
  s.silu = silu;
  const std::vector<float> got = run_gpu(s, x, gamma, max_binding_bytes, in_place);
  size_t bad = 0;
  double worst = 0.0;
  for (size_t i = 0; i < got.size(); ++i) {
    const double zi = std::abs(static_cast<double>(z.data[i]));
    const double tol = 1e-6 + std::ldexp(1.0, -23) * (static_cast<double>(C) + 16.0 + 2.0 * zi) * zi;
    const double err = std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i]));
    worst = std::max(worst, err / tol);
    if (!(err <= tol) && ++bad <= 5)
      std::printf("  rms_norm mismatch at %zu: got %.9g want %.9g (tol %.3g)\n", i, static_cast<double>(got[i]),
                  static_cast<double>(want.data[i]), tol);
  }
  std::printf("  rms_norm %lldx%lldx%lldx%lld silu %d cap %llu in place %d: worst error %.3g of the bound\n", static_cast<long long>(B),
              static_cast<long long>(C), static_cast<long long>(H), static_cast<long long>(W), silu ? 1 : 0,
              static_cast<unsigned long long>(max_binding_bytes), in_place ? 1 : 0, worst);
  CHECK(bad == 0);
}

// A frame-kernel-1 conv weight (out, in, 1, k, k) as (out, in, k, k).
nn::CpuTensor weight_2d(const nn::CpuTensor& t) {
  REQUIRE(t.rank() == 5);
  REQUIRE(t.dim(2) == 1);
  return nn::CpuTensor({t.dim(0), t.dim(1), t.dim(3), t.dim(4)}, t.data);
}

nn::CpuTensor frames_to_2d(const nn::CpuTensor& t) {
  REQUIRE(t.rank() == 5);
  return nn::CpuTensor({t.dim(0), t.dim(1), t.dim(3), t.dim(4)}, t.data);
}

// x-unet's ResnetBlock without res_conv on the GPU: silu(rms(conv(silu(rms(conv(x)))))) + x, 3x3 convs with bias.
nn::CpuTensor gpu_resnet_block(const nn::GsmWeights& w, const std::string& p, const nn::CpuTensor& x) {
  REQUIRE_MESSAGE(!w.has(p + "res_conv.weight"), p << " has a res_conv (the test covers identity skips)");
  gpu::Context& ctx = test::gpu_context();
  const uint32_t B = static_cast<uint32_t>(x.dim(0)), C = static_cast<uint32_t>(x.dim(1));
  const uint32_t H = static_cast<uint32_t>(x.dim(2)), W = static_cast<uint32_t>(x.dim(3));
  const size_t n = x.data.size();
  auto packed = [&](const std::string& name) {
    const nn::CpuTensor k = weight_2d(w.at(name));
    REQUIRE(k.dim(0) == C);
    REQUIRE(k.dim(1) == C);
    return gpu::upload_vector(ctx, kernels::nn::pack_conv2d_weights(k.data, C, C, 3, 3), name);
  };
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data, "block-x");
  gpu::Buffer w1 = packed(p + "block1.proj.weight"), w2 = packed(p + "block2.proj.weight");
  gpu::Buffer b1 = gpu::upload_vector(ctx, w.at(p + "block1.proj.bias").data, "b1");
  gpu::Buffer b2 = gpu::upload_vector(ctx, w.at(p + "block2.proj.bias").data, "b2");
  gpu::Buffer g1 = gpu::upload_vector(ctx, w.at(p + "block1.norm.gamma").data, "g1");
  gpu::Buffer g2 = gpu::upload_vector(ctx, w.at(p + "block2.norm.gamma").data, "g2");
  gpu::Buffer h1(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "block-h1"), h2(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "block-h2");
  gpu::Buffer yb(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "block-y");
  kernels::nn::Conv2d conv(ctx);
  kernels::nn::RmsNorm norm(ctx);
  kernels::nn::Elementwise ew(ctx);
  const kernels::nn::Conv2dShape cs{B, C, C, H, W, 3, 3, 1, 1};
  kernels::nn::RmsNormShape ns;
  ns.batch = B;
  ns.channels = C;
  ns.plane = uint64_t{H} * W;
  ns.silu = true;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    conv.record(cmd, cs, xb, w1, &b1, h1);
    cmd.barrier(gpu::deps::kComputeToCompute);
    norm.record(cmd, ns, h1, g1, h1);  // in place
    cmd.barrier(gpu::deps::kComputeToCompute);
    conv.record(cmd, cs, h1, w2, &b2, h2);
    cmd.barrier(gpu::deps::kComputeToCompute);
    norm.record(cmd, ns, h2, g2, h2);
    cmd.barrier(gpu::deps::kComputeToCompute);
    ew.add(cmd, h2, xb, n, yb);
  });
  return nn::CpuTensor({B, C, 1, H, W}, gpu::download_vector<float>(ctx, yb, n));
}

}  // namespace

TEST_CASE("rms_norm gpu: x-unet's RMSNorm (and + SiLU) against the CPU reference") {
  const std::vector<float> one{1.0f};
  check_rms_norm(3, 5, 7, 9, false, one, 1);   // batch 3, odd image and channels
  check_rms_norm(3, 5, 7, 9, true, one, 2);    // fused SiLU (x-unet's Block)
  check_rms_norm(1, 1, 5, 3, true, one, 3);    // one channel: sign(x) * gamma
  check_rms_norm(2, 64, 6, 10, true, one, 4);  // x-unet's widths
  check_rms_norm(1, 333, 3, 5, false, one, 5);
  // Extreme pixels: the eps clamp (1e-20: the underflow path; 1e-14: norms below eps in the fast path),
  // large activations, the overflow path (1e25) and all-zero pixels, next to ordinary ones.
  const std::vector<float> extreme{1e-20f, 1.0f, 1e-14f, 3e4f, 1e25f, 0.0f, 0.25f};
  check_rms_norm(2, 7, 5, 9, false, extreme, 6);
  check_rms_norm(2, 64, 5, 9, true, extreme, 7);
  check_rms_norm(1, 6, 4, 5, true, extreme, 8, 0, true);  // in place (y = x)
}

TEST_CASE("rms_norm gpu: windows over a capped binding, the loop budget and the refusals") {
  gpu::Context& ctx = test::gpu_context();
  const uint64_t align = std::max<uint64_t>({4, ctx.info().min_storage_buffer_offset_alignment,
                                             ctx.info().min_texel_buffer_offset_alignment});
  const std::vector<float> mixed{1.0f, 1e25f, 1e-20f, 3.0f};
  // Two whole batch elements (2 x 5 x 63 floats) per window of 5 elements, at unaligned offsets.
  check_rms_norm(5, 5, 7, 9, true, mixed, 11, 2 * 5 * 63 * 4 + align);
  // Pixel windows of one element: 4 x 63 + 10 floats bind every channel of 10 pixels.
  check_rms_norm(2, 5, 7, 9, true, mixed, 12, (4 * 63 + 10) * 4 + align);
  check_rms_norm(2, 5, 7, 9, false, mixed, 13, (4 * 63 + 10) * 4 + align, true);  // and in place
  // 20,000 channels (the overflow path's three loops: 60,000 iterations) on 3 pixels.
  check_rms_norm(1, 20000, 1, 3, true, {1e25f, 1.0f, 1e-20f}, 14);

  gpu::Buffer buf(ctx, 4 * 20001 * 4, gpu::MemoryUsage::DeviceLocal, "rms-refuse");
  kernels::nn::RmsNorm norm(ctx);
  kernels::nn::RmsNormShape s;
  s.channels = 20001;
  s.plane = 1;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_AS(norm.record(cmd, s, buf, buf, buf), std::invalid_argument);  // beyond the loop budget
    s.channels = 5;
    s.plane = 100;
    norm.set_max_binding_bytes(4 * 100 * 4);  // the 4 x 100 floats between a pixel's first and last channel do not fit
    CHECK_THROWS_AS(norm.record(cmd, s, buf, buf, buf), std::invalid_argument);
  });
}

TEST_CASE("rms_norm gpu: gsm_small's x-unet ResnetBlocks (conv -> RMSNorm + SiLU, twice, + x)") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nlohmann::json unet = nlohmann::json::parse(scene::read_file(dir + "config.json"))
                                  .at("hparams").at("backbone").at("params").at("backbone_2d_params").at("unet2d_params");
  REQUIRE_FALSE(unet.value("weight_standardize", false));  // plain convs
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const std::string net = "backbone.backbone_2d.net.";
  for (int s = 0; s < 4; ++s) {
    const std::string n = "pix.unet.downs." + std::to_string(s);
    const std::string first_in = s == 0 ? "pix.unet.init_conv" : "pix.unet.downs." + std::to_string(s - 1) + ".3";
    test::check_gsm_tensor(ref, n + ".0", gpu_resnet_block(w, net + "downs." + std::to_string(s) + ".0.", frames_to_2d(ref.get(first_in))));
    test::check_gsm_tensor(ref, n + ".1.0",
                           gpu_resnet_block(w, net + "downs." + std::to_string(s) + ".1.0.", frames_to_2d(ref.get(n + ".0"))));
  }
}
