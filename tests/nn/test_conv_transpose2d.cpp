// ConvTranspose2d: the CPU reference (nn::cpu::conv_transpose2d) against its
// scatter form, then the GPU kernel (kernels/nn/conv_transpose2d.h,
// shaders/nn/conv_transpose2d.comp) against the CPU reference at the GSM's
// shapes — kernel 4 stride 2 padding 1 (x-unet's Upsample), kernel = stride = 4
// and 2 (Depth-Anything's reassemble) — and others (3x3 stride 2, stride 3,
// stride 1, a non-square kernel, padding beyond the kernel's reach, a 1x1
// input), at odd sizes, batch 3, channel counts that are not multiples of the
// 8-channel tile, without bias, with large activations, and in windows (a
// capped binding splitting x, y and the packed weights; input channels beyond
// one dispatch's loop budget). The bound per element is float32 accumulation's:
// 1e-6 + n 2^-23 sum |w x| over the n products that reach it. Then the official
// gsm_small case: x-unet's mid_upsample / ups.*.3 and Depth-Anything's
// reassemble.0 / .1 from the reference inputs. Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/conv_transpose2d.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <tuple>

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

// y of the GPU kernel for x, w [Ci, Co, kh, kw], bias (or none).
std::vector<float> run_gpu(const kernels::nn::ConvTranspose2dShape& s, const nn::CpuTensor& x, const nn::CpuTensor& w,
                           const nn::CpuTensor* bias, uint64_t max_binding_bytes = 0) {
  gpu::Context& ctx = test::gpu_context();
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data, "convt2d-x");
  gpu::Buffer wb = gpu::upload_vector(
      ctx, kernels::nn::pack_conv_transpose2d_weights(w.data, s.in_channels, s.out_channels, s.kernel_h, s.kernel_w), "convt2d-w");
  gpu::Buffer bb = gpu::upload_vector(ctx, bias ? bias->data : std::vector<float>{0.0f}, "convt2d-b");
  const size_t n = size_t{s.batch} * s.out_channels * s.out_height() * s.out_width();
  gpu::Buffer yb(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "convt2d-y");
  kernels::nn::ConvTranspose2d conv(ctx);
  conv.set_max_binding_bytes(max_binding_bytes);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, xb, wb, bias ? &bb : nullptr, yb); });
  return gpu::download_vector<float>(ctx, yb, n);
}

void check_conv_transpose2d(const kernels::nn::ConvTranspose2dShape& s, bool with_bias, float x_scale, uint32_t seed,
                            uint64_t max_binding_bytes = 0) {
  CAPTURE(s.batch);
  CAPTURE(s.in_channels);
  CAPTURE(s.out_channels);
  CAPTURE(s.height);
  CAPTURE(s.width);
  CAPTURE(s.kernel_h);
  CAPTURE(s.kernel_w);
  CAPTURE(s.stride);
  CAPTURE(s.padding);
  CAPTURE(max_binding_bytes);
  const nn::CpuTensor x = random_tensor({s.batch, s.in_channels, s.height, s.width}, seed, x_scale);
  const nn::CpuTensor w = random_tensor({s.in_channels, s.out_channels, s.kernel_h, s.kernel_w}, seed + 1, 0.5f);
  const nn::CpuTensor b = random_tensor({s.out_channels}, seed + 2, 1.0f);
  const int stride = static_cast<int>(s.stride), pad = static_cast<int>(s.padding);
  const nn::CpuTensor want = nn::cpu::conv_transpose2d(x, w, with_bias ? &b : nullptr, stride, pad);
  const nn::CpuTensor bound = nn::cpu::conv_transpose2d(abs_of(x), abs_of(w), nullptr, stride, pad);
  REQUIRE(want.dim(2) == s.out_height());
  REQUIRE(want.dim(3) == s.out_width());
  const std::vector<float> got = run_gpu(s, x, w, with_bias ? &b : nullptr, max_binding_bytes);
  const double n = static_cast<double>(s.in_channels) * static_cast<double>((s.kernel_h + s.stride - 1) / s.stride) *
                   static_cast<double>((s.kernel_w + s.stride - 1) / s.stride);
  size_t bad = 0;
  double worst = 0.0;
  for (size_t i = 0; i < got.size(); ++i) {
    const double tol = 1e-6 + n * std::ldexp(1.0, -23) * static_cast<double>(bound.data[i]);
    const double err = std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i]));
    worst = std::max(worst, err / tol);
    if (!(err <= tol) && ++bad <= 5)
      std::printf("  conv_transpose2d mismatch at %zu: got %.9g want %.9g (tol %.3g)\n", i, static_cast<double>(got[i]),
                  static_cast<double>(want.data[i]), tol);
  }
  std::printf("  conv_transpose2d %ux%u->%u %ux%u k%ux%u s%u p%u cap %llu: worst error %.3g of the bound\n", s.batch, s.in_channels,
              s.out_channels, s.height, s.width, s.kernel_h, s.kernel_w, s.stride, s.padding,
              static_cast<unsigned long long>(max_binding_bytes), worst);
  CHECK(bad == 0);
}

// A frame-kernel-1 ConvTranspose3d weight (in, out, 1, kh, kw) or a 2-D one as [in, out, kh, kw].
nn::CpuTensor weight_2d(const nn::CpuTensor& t) {
  if (t.rank() == 4) return t;
  REQUIRE(t.rank() == 5);
  REQUIRE(t.dim(2) == 1);
  return nn::CpuTensor({t.dim(0), t.dim(1), t.dim(3), t.dim(4)}, t.data);
}

// The GPU transposed convolution of the gsm_small reference tensor x [B, C, (1,) H, W] with the weights under `prefix`.
nn::CpuTensor gpu_conv_transpose(const nn::GsmWeights& weights, const std::string& prefix, const nn::CpuTensor& x_in, int stride,
                                 int padding) {
  const nn::CpuTensor w = weight_2d(weights.at(prefix + "weight"));
  const nn::CpuTensor& bias = weights.at(prefix + "bias");
  const int64_t H = x_in.dim(x_in.rank() - 2), W = x_in.dim(x_in.rank() - 1);
  kernels::nn::ConvTranspose2dShape s;
  s.batch = static_cast<uint32_t>(x_in.dim(0));
  s.in_channels = static_cast<uint32_t>(w.dim(0));
  s.out_channels = static_cast<uint32_t>(w.dim(1));
  s.height = static_cast<uint32_t>(H);
  s.width = static_cast<uint32_t>(W);
  s.kernel_h = static_cast<uint32_t>(w.dim(2));
  s.kernel_w = static_cast<uint32_t>(w.dim(3));
  s.stride = static_cast<uint32_t>(stride);
  s.padding = static_cast<uint32_t>(padding);
  REQUIRE(x_in.dim(1) == w.dim(0));
  return nn::CpuTensor({x_in.dim(0), w.dim(1), s.out_height(), s.out_width()}, run_gpu(s, x_in, w, &bias));
}

nn::CpuTensor as_frames(const nn::CpuTensor& x) { return nn::CpuTensor({x.dim(0), x.dim(1), 1, x.dim(2), x.dim(3)}, x.data); }

}  // namespace

TEST_CASE("conv_transpose2d reference: equals its scatter form") {
  for (const auto& [stride, pad, k] : {std::tuple{4, 0, 4}, std::tuple{2, 0, 2}, std::tuple{2, 1, 3}, std::tuple{3, 1, 4}}) {
    CAPTURE(stride);
    CAPTURE(pad);
    CAPTURE(k);
    const nn::CpuTensor x = random_tensor({2, 3, 4, 5}, 7, 1.0f);
    const nn::CpuTensor w = random_tensor({3, 6, k, k}, 8, 1.0f);
    const nn::CpuTensor b = random_tensor({6}, 9, 1.0f);
    const nn::CpuTensor y = nn::cpu::conv_transpose2d(x, w, &b, stride, pad);
    const int64_t OH = 3 * stride - 2 * pad + k, OW = 4 * stride - 2 * pad + k;
    REQUIRE(y.shape == std::vector<int64_t>{2, 6, OH, OW});
    // Scatter: each input pixel adds w * x at (i s - p + ky, j s - p + kx).
    std::vector<double> want(y.data.size());
    for (int64_t bb = 0; bb < 2; ++bb)
      for (int64_t o = 0; o < 6; ++o)
        for (int64_t r = 0; r < OH * OW; ++r) want[static_cast<size_t>((bb * 6 + o) * OH * OW + r)] = b.data[static_cast<size_t>(o)];
    for (int64_t bb = 0; bb < 2; ++bb)
      for (int64_t c = 0; c < 3; ++c)
        for (int64_t i = 0; i < 4; ++i)
          for (int64_t j = 0; j < 5; ++j)
            for (int64_t o = 0; o < 6; ++o)
              for (int64_t ky = 0; ky < k; ++ky)
                for (int64_t kx = 0; kx < k; ++kx) {
                  const int64_t oy = i * stride - pad + ky, ox = j * stride - pad + kx;
                  if (oy < 0 || oy >= OH || ox < 0 || ox >= OW) continue;
                  want[static_cast<size_t>(((bb * 6 + o) * OH + oy) * OW + ox)] +=
                      static_cast<double>(w.data[static_cast<size_t>(((c * 6 + o) * k + ky) * k + kx)]) *
                      static_cast<double>(x.data[static_cast<size_t>(((bb * 3 + c) * 4 + i) * 5 + j)]);
                }
    std::vector<float> wantf(want.begin(), want.end());
    CHECK(test::allclose(y.data, wantf, 1e-5, 1e-5, "conv_transpose2d"));
  }
}

TEST_CASE("conv_transpose2d gpu: the GSM's up-projections and other strides against the CPU reference") {
  using S = kernels::nn::ConvTranspose2dShape;
  //            batch ci co  h   w  kh kw  s  p
  check_conv_transpose2d(S{3, 5, 11, 7, 9, 4, 4, 2, 1}, true, 1.0f, 1);    // x-unet's Upsample, batch 3, odd sizes
  check_conv_transpose2d(S{1, 9, 13, 4, 6, 4, 4, 4, 0}, true, 1.0f, 11);   // reassemble x4 (kernel = stride)
  check_conv_transpose2d(S{2, 7, 10, 5, 3, 2, 2, 2, 0}, false, 1.0f, 21);  // reassemble x2, no bias
  check_conv_transpose2d(S{1, 6, 9, 5, 7, 3, 3, 2, 1}, true, 1.0f, 31);    // 3x3 stride 2 (odd output)
  check_conv_transpose2d(S{1, 4, 5, 6, 5, 4, 4, 3, 1}, true, 1.0f, 41);    // stride 3: uneven taps per phase
  check_conv_transpose2d(S{1, 3, 8, 6, 7, 3, 3, 1, 1}, true, 1.0f, 51);    // stride 1 (a flipped conv)
  check_conv_transpose2d(S{2, 5, 6, 5, 8, 3, 5, 2, 2}, true, 1.0f, 61);    // non-square kernel, padding 2
  check_conv_transpose2d(S{1, 4, 8, 1, 1, 4, 4, 2, 1}, true, 1.0f, 71);    // one input pixel
  check_conv_transpose2d(S{1, 2, 3, 1, 2, 1, 1, 3, 0}, true, 1.0f, 81);    // 1x1 kernel, stride 3: zeros between
  check_conv_transpose2d(S{1, 5, 9, 6, 7, 4, 4, 2, 1}, true, 3e4f, 91);    // large activations
}

TEST_CASE("conv_transpose2d gpu: windows over a capped binding and beyond one dispatch's loop budget") {
  using S = kernels::nn::ConvTranspose2dShape;
  const uint64_t align = std::max<uint64_t>({4, test::gpu_context().info().min_storage_buffer_offset_alignment,
                                             test::gpu_context().info().min_texel_buffer_offset_alignment});
  // Output planes of 14 x 18: y windows of 8 channels (the cap), x and weight windows of 5 input channels
  // (a packed weight row is 16 taps x 6 vec4s x 16 bytes) at unaligned offsets, batch 2.
  const uint64_t cap = 8 * 14 * 18 * 4 + align;
  check_conv_transpose2d(S{2, 19, 21, 7, 9, 4, 4, 2, 1}, true, 1.0f, 101, cap);
  // The packed weights (9 input channels x 1.5 KiB) over a 2 KiB binding: weight windows of one input
  // channel, accumulating, and y windows of 8 of the 20 output channels.
  check_conv_transpose2d(S{1, 9, 20, 3, 4, 4, 4, 2, 1}, true, 1.0f, 111, 2048);
  // Kernel 4 stride 2 over 3000 input channels: input-channel windows that accumulate (lavapipe's 65,535 iterations).
  check_conv_transpose2d(S{1, 3000, 9, 2, 3, 4, 4, 2, 1}, true, 1.0f, 121);
}

TEST_CASE("conv_transpose2d gpu: gsm_small's x-unet upsamples and Depth-Anything reassembles") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmWeights weights = nn::load_gsm_weights(dir + "weights.safetensors");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const std::string unet = "backbone.backbone_2d.net.";
  // x-unet's Upsample: ConvTranspose3d kernel (1, 4, 4), stride (1, 2, 2), padding (0, 1, 1).
  auto frames_to_2d = [](nn::CpuTensor t) {
    REQUIRE(t.rank() == 5);
    return nn::CpuTensor({t.dim(0), t.dim(1), t.dim(3), t.dim(4)}, t.data);
  };
  test::check_gsm_tensor(ref, "pix.unet.mid_upsample",
                         as_frames(gpu_conv_transpose(weights, unet + "mid_upsample.", frames_to_2d(ref.get("pix.unet.mid_after")), 2, 1)));
  for (int u = 0; u < 3; ++u) {
    const std::string n = "pix.unet.ups." + std::to_string(u);
    test::check_gsm_tensor(ref, n + ".3",
                           as_frames(gpu_conv_transpose(weights, unet + "ups." + std::to_string(u) + ".3.",
                                                        frames_to_2d(ref.get(n + ".1.0")), 2, 1)));
  }
  // Depth-Anything's reassemble 0 and 1: tokens (CLS dropped) as the 4 x 6 patch map, the 1x1 projection on
  // the GPU (conv2d), then the x4 / x2 transposed convolution.
  const std::string neck = "img_encoder.encoders.dav2.model.neck.reassemble_stage.layers.";
  gpu::Context& ctx = test::gpu_context();
  for (int k = 0; k < 2; ++k) {
    const nn::CpuTensor tokens = ref.get("enc.dav2.feature_maps." + std::to_string(k));  // [1, 1 + 4 * 6, C]
    const int64_t C = tokens.dim(2), ph = 4, pw = 6;
    REQUIRE(tokens.dim(1) == 1 + ph * pw);
    nn::CpuTensor map({1, C, ph, pw});
    for (int64_t c = 0; c < C; ++c)
      for (int64_t t = 0; t < ph * pw; ++t) map.data[static_cast<size_t>(c * ph * pw + t)] = tokens.data[static_cast<size_t>((1 + t) * C + c)];
    const std::string r = neck + std::to_string(k) + ".";
    const nn::CpuTensor& pw_ = weights.at(r + "projection.weight");
    const uint32_t Co = static_cast<uint32_t>(pw_.dim(0));
    kernels::nn::Conv2dShape ps{1, static_cast<uint32_t>(C), Co, ph, pw, 1, 1, 1, 0};
    gpu::Buffer xb = gpu::upload_vector(ctx, map.data, "reassemble-map");
    gpu::Buffer wb = gpu::upload_vector(ctx, kernels::nn::pack_conv2d_weights(pw_.data, Co, ps.in_channels, 1, 1), "reassemble-pw");
    gpu::Buffer bb = gpu::upload_vector(ctx, weights.at(r + "projection.bias").data, "reassemble-pb");
    gpu::Buffer yb(ctx, uint64_t{Co} * ph * pw * 4, gpu::MemoryUsage::DeviceLocal, "reassemble-p");
    kernels::nn::Conv2d proj(ctx);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { proj.record(cmd, ps, xb, wb, &bb, yb); });
    const nn::CpuTensor projected({1, Co, ph, pw}, gpu::download_vector<float>(ctx, yb, size_t{Co} * ph * pw));
    const int factor = k == 0 ? 4 : 2;
    test::check_gsm_tensor(ref, "enc.dav2.reassemble." + std::to_string(k),
                           gpu_conv_transpose(weights, r + "resize.", projected, factor, 0));
  }
}
