// conv2d on the GPU (kernels/nn/conv2d.h, shaders/nn/conv2d.comp) against the
// CPU reference (nn::cpu::conv2d) at the GSM's shapes — 3x3 padding 1, 1x1,
// 3x3 stride 2 (Depth-Anything's reassemble), the 14x14 and 16x16 patch
// embeddings (stride = kernel) — at odd sizes, batch 3, channel counts that are
// not multiples of the 8-channel tile, without bias, with large activations,
// and in windows (a capped binding; input channels beyond one dispatch's loop
// budget). The bound per element is float32 accumulation's: 1e-6 + n 2^-23
// sum |w x| over the n = Ci kh kw products. Runs under the validation layer.
// (The transposed convolution: tests/nn/test_conv_transpose2d.cpp.)
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "kernels/nn/conv2d.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

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

void check_conv2d(const kernels::nn::Conv2dShape& s, bool with_bias, float x_scale, uint32_t seed, uint64_t max_binding_bytes = 0) {
  CAPTURE(s.batch);
  CAPTURE(s.in_channels);
  CAPTURE(s.out_channels);
  CAPTURE(s.height);
  CAPTURE(s.width);
  CAPTURE(s.kernel_h);
  CAPTURE(s.stride);
  CAPTURE(s.padding);
  CAPTURE(max_binding_bytes);
  gpu::Context& ctx = test::gpu_context();
  const nn::CpuTensor x = random_tensor({s.batch, s.in_channels, s.height, s.width}, seed, x_scale);
  const nn::CpuTensor w = random_tensor({s.out_channels, s.in_channels, s.kernel_h, s.kernel_w}, seed + 1, 0.5f);
  const nn::CpuTensor b = random_tensor({s.out_channels}, seed + 2, 1.0f);
  const int stride = static_cast<int>(s.stride), pad = static_cast<int>(s.padding);
  const nn::CpuTensor want = nn::cpu::conv2d(x, w, with_bias ? &b : nullptr, stride, pad);
  const nn::CpuTensor bound = nn::cpu::conv2d(abs_of(x), abs_of(w), nullptr, stride, pad);
  REQUIRE(want.dim(2) == s.out_height());
  REQUIRE(want.dim(3) == s.out_width());
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data, "conv2d-x");
  gpu::Buffer wb = gpu::upload_vector(ctx, kernels::nn::pack_conv2d_weights(w.data, s.out_channels, s.in_channels, s.kernel_h, s.kernel_w), "conv2d-w");
  gpu::Buffer bb = gpu::upload_vector(ctx, b.data, "conv2d-b");
  gpu::Buffer yb(ctx, want.data.size() * 4, gpu::MemoryUsage::DeviceLocal, "conv2d-y");
  kernels::nn::Conv2d conv(ctx);
  conv.set_max_binding_bytes(max_binding_bytes);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, s, xb, wb, with_bias ? &bb : nullptr, yb); });
  const std::vector<float> got = gpu::download_vector<float>(ctx, yb, want.data.size());
  const double n = static_cast<double>(s.in_channels) * s.kernel_h * s.kernel_w;
  size_t bad = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const double tol = 1e-6 + n * std::ldexp(1.0, -23) * static_cast<double>(bound.data[i]);
    const double err = std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i]));
    if (!(err <= tol) && ++bad <= 5)
      std::printf("  conv2d mismatch at %zu: got %.9g want %.9g (tol %.3g)\n", i, static_cast<double>(got[i]),
                  static_cast<double>(want.data[i]), tol);
  }
  CHECK(bad == 0);
}

}  // namespace

TEST_CASE("conv2d gpu: 3x3, 1x1, stride 2 and patch embeddings against the CPU reference") {
  using S = kernels::nn::Conv2dShape;
  check_conv2d(S{3, 5, 11, 13, 17, 3, 3, 1, 1}, true, 1.0f, 1);     // batch 3, odd image and channel counts
  check_conv2d(S{1, 9, 7, 6, 10, 1, 1, 1, 0}, true, 1.0f, 11);      // 1x1 projection
  check_conv2d(S{1, 6, 10, 7, 9, 3, 3, 2, 1}, false, 1.0f, 21);     // 3x3 stride 2 (odd input), no bias
  check_conv2d(S{2, 3, 12, 28, 42, 14, 14, 14, 0}, true, 1.0f, 31); // DINOv2's 14x14 patch embedding
  check_conv2d(S{1, 3, 9, 32, 48, 16, 16, 16, 0}, true, 1.0f, 41);  // the sky's 16x16 patch embedding
  check_conv2d(S{1, 4, 8, 1, 1, 3, 3, 1, 1}, true, 1.0f, 51);       // one pixel: only the centre tap
  check_conv2d(S{1, 5, 9, 9, 11, 3, 3, 1, 1}, true, 3e4f, 61);      // large activations
  check_conv2d(S{1, 5, 9, 5, 5, 5, 3, 1, 2}, true, 1.0f, 71);       // a wide padding and a non-square kernel
}

TEST_CASE("conv2d gpu: windows over a capped binding and beyond one dispatch's loop budget") {
  using S = kernels::nn::Conv2dShape;
  const uint64_t align = std::max<uint64_t>(4, test::gpu_context().info().min_storage_buffer_offset_alignment);
  // Per-channel windows of x and y at unaligned offsets, batch 2.
  check_conv2d(S{2, 19, 21, 7, 9, 3, 3, 1, 1}, true, 1.0f, 81, 7 * 9 * 4 * 9 + align);
  check_conv2d(S{1, 10, 17, 8, 6, 3, 3, 2, 1}, true, 1.0f, 91, 8 * 6 * 4 * 9 + align);
  // 3x3 kernels over 5000 input channels: input-channel windows that accumulate (lavapipe's 65,535 iterations).
  check_conv2d(S{1, 5000, 9, 3, 4, 3, 3, 1, 1}, true, 1.0f, 101);
}
