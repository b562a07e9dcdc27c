// The element-wise and resampling kernels (kernels/nn/elementwise.h) against
// the CPU references: SiLU and GEGLU (exact-erf GELU) over a sweep of values
// including large magnitudes, add, 2x2x2 average pooling of odd sizes and
// nearest x2 upsampling (exact), batch x channels planes. Validation on.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "nn/elementwise.h"
#include "nn/layers_cpu.h"

#include <cmath>
#include <random>

using namespace icube;

namespace {

std::vector<float> sweep(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-6.f, 6.f);
  std::vector<float> v(n);
  for (float& f : v) f = u(rng);
  // Extremes and the erf branch boundary.
  const float special[] = {0.f, -0.f, 1e-8f, -1e-8f, 2.828f, 2.8285f, -2.8285f, 30.f, -30.f, 88.f, -88.f, 1e4f, -1e4f};
  for (size_t i = 0; i < sizeof special / sizeof special[0] && i < n; ++i) v[i] = special[i];
  return v;
}

}  // namespace

TEST_CASE("nn elementwise gpu: SiLU, add, GEGLU against the CPU reference") {
  // 0: the device's binding limit; 1000 B: SiLU, add and GEGLU (per batch element, its value and
  // gate halves of 185 elements) in windows of 246 elements (off the alignment); 400 B: windows of
  // 96 elements, two per GEGLU half.
  for (const uint64_t limit : {uint64_t{0}, uint64_t{1000}, uint64_t{400}}) {
  CAPTURE(limit);
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::Elementwise ew(ctx);
  ew.set_max_binding_bytes(limit);
  const uint32_t batch = 2, channels = 5, tokens = 37;
  const std::vector<float> a = sweep(2 * batch * channels * tokens, 1), b = sweep(a.size(), 2);
  gpu::Buffer ab = gpu::upload_vector(ctx, a), bb = gpu::upload_vector(ctx, b);
  gpu::Buffer y1(ctx, a.size() * 4), y2(ctx, a.size() * 4), y3(ctx, a.size() * 2);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    ew.silu(cmd, ab, a.size(), y1);
    ew.add(cmd, ab, bb, a.size(), y2);
    ew.geglu(cmd, ab, batch, channels, tokens, y3);
  });
  const nn::CpuTensor ta({static_cast<int64_t>(a.size())}, a), tb({static_cast<int64_t>(b.size())}, b);
  CHECK(test::allclose(gpu::download_vector<float>(ctx, y1, a.size()), nn::cpu::silu(ta).data, 1e-6, 1e-6, "silu"));
  CHECK(test::allclose(gpu::download_vector<float>(ctx, y2, a.size()), nn::cpu::add(ta, tb).data, 0.0, 0.0, "add"));
  // GEGLU reference: value half * gelu(gate half), per batch element.
  std::vector<float> want;
  const size_t per = size_t{channels} * tokens;
  for (uint32_t n = 0; n < batch; ++n) {
    const nn::CpuTensor gate({static_cast<int64_t>(per)}, std::vector<float>(a.begin() + (2 * n + 1) * per, a.begin() + (2 * n + 2) * per));
    const nn::CpuTensor g = nn::cpu::gelu(gate);
    for (size_t i = 0; i < per; ++i) want.push_back(a[2 * n * per + i] * g.data[i]);
  }
  // GELU's absolute error (erf to ~3e-7, times |gate| / 2 <= 3) scales with the value it gates:
  // |got - want| <= 1e-6 (1 + |value|) + 2e-6 |want|.
  const std::vector<float> got = gpu::download_vector<float>(ctx, y3, want.size());
  size_t bad = 0;
  for (size_t i = 0; i < want.size(); ++i) {
    const size_t n = i / per, r = i % per;
    const double value = std::abs(static_cast<double>(a[2 * n * per + r]));
    const double tol = 1e-6 * (1.0 + value) + 2e-6 * std::abs(static_cast<double>(want[i]));
    if (!(std::abs(static_cast<double>(got[i]) - static_cast<double>(want[i])) <= tol) && ++bad <= 5)
      MESSAGE("geglu " << i << ": got " << got[i] << " want " << want[i]);
  }
  CHECK(bad == 0);
  }
}

TEST_CASE("nn elementwise gpu: average pooling and nearest upsampling are exact") {
  // 0: the device's binding limit. 2400 B: pooling in windows of whole planes (140 inputs = 560 B
  // a plane); an upsampled plane (4,480 B) does not fit, so upsampling runs in slabs of 4 output x
  // slices. 300 B: a pooled plane's input does not fit either: pooling in slabs of one output x
  // slice; one upsampled x slice (448 B) exceeds the binding, refused by name.
  for (const uint64_t limit : {uint64_t{0}, uint64_t{2400}, uint64_t{300}}) {
  CAPTURE(limit);
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::Elementwise ew(ctx);
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
