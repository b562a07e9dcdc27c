// The resampling kernels (kernels/nn/resample.h) against the CPU references:
// 2x2x2 average pooling of odd sizes and nearest x2 upsampling (exact), batch x
// channels planes, in windows of planes and slabs of x slices under small
// binding caps; the CPU references on a known case. Validation on.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "kernels/nn/resample.h"

#include <random>

using namespace icube;

TEST_CASE("nn resample gpu: average pooling and nearest upsampling are exact") {
  // 0: the device's binding limit. 2400 B: pooling in windows of whole planes (140 inputs = 560 B
  // a plane); an upsampled plane (4,480 B) does not fit, so upsampling runs in slabs of 4 output x
  // slices. 300 B: a pooled plane's input does not fit either: pooling in slabs of one output x
  // slice; one upsampled x slice (448 B) exceeds the binding, refused by name.
  for (const uint64_t limit : {uint64_t{0}, uint64_t{2400}, uint64_t{300}}) {
  CAPTURE(limit);
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::Resample ew(ctx);
  nn::CpuTensor x({2, 3, 5, 4, 7});
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-6.f, 6.f);
  for (float& v : x.data) v = u(rng);
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data);
  const nn::CpuTensor pool = nn::cpu::avg_pool2(x), up = nn::cpu::upsample2(x);
  gpu::Buffer pb(ctx, pool.data.size() * 4), ub(ctx, up.data.size() * 4);
  ew.set_max_binding_bytes(limit);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { ew.avg_pool2(cmd, xb, 6, 5, 4, 7, pb); });
  CHECK(test::allclose(gpu::download_vector<float>(ctx, pb, pool.data.size()), pool.data, 1e-6, 1e-6, "avg_pool2"));
  if (limit != 300) {
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { ew.upsample2(cmd, xb, 6, 5, 4, 7, ub); });
    CHECK(test::allclose(gpu::download_vector<float>(ctx, ub, up.data.size()), up.data, 0.0, 0.0, "upsample2"));
  } else {
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      CHECK_THROWS_WITH_AS(ew.upsample2(cmd, xb, 6, 5, 4, 7, ub), doctest::Contains("one x slice of 4x7 exceeds"),
                           std::invalid_argument);
    });
  }
  gpu::Buffer tiny(ctx, 64);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(ew.avg_pool2(cmd, tiny, 1, 1, 4, 4, tiny), doctest::Contains("shorter than 2"), std::invalid_argument);
  });
  }
}

TEST_CASE("nn resample cpu: pooling floors odd sizes, upsampling repeats every value") {
  nn::CpuTensor x({1, 1, 2, 2, 3});
  for (int i = 0; i < 12; ++i) x.data[static_cast<size_t>(i)] = static_cast<float>(i);
  const nn::CpuTensor p = nn::cpu::avg_pool2(x);  // floors Z = 3 to 1
  REQUIRE(p.shape == std::vector<int64_t>{1, 1, 1, 1, 1});
  CHECK(p.data[0] == doctest::Approx((0 + 1 + 3 + 4 + 6 + 7 + 9 + 10) / 8.0));
  const nn::CpuTensor u = nn::cpu::upsample2(x);
  CHECK(u.shape == std::vector<int64_t>{1, 1, 4, 4, 6});
  CHECK(u.data[static_cast<size_t>((3 * 4 + 3) * 6 + 5)] == 11.0f);
}
