// The element-wise kernels (kernels/nn/elementwise.h) against the CPU
// references: SiLU and GEGLU (exact-erf GELU) over a sweep of values including
// large magnitudes, add; the CPU references on known values. Validation on.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "kernels/nn/elementwise.h"

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

TEST_CASE("nn elementwise gpu: SiLU, GELU, ReLU, add, GEGLU against the CPU reference") {
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
  gpu::Buffer y1(ctx, a.size() * 4), y2(ctx, a.size() * 4), y3(ctx, a.size() * 2), y4(ctx, a.size() * 4), y5(ctx, a.size() * 4);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    ew.silu(cmd, ab, a.size(), y1);
    ew.add(cmd, ab, bb, a.size(), y2);
    ew.geglu(cmd, ab, batch, channels, tokens, y3);
    ew.gelu(cmd, ab, a.size(), y4);
    ew.relu(cmd, ab, a.size(), y5);
  });
  const nn::CpuTensor ta({static_cast<int64_t>(a.size())}, a), tb({static_cast<int64_t>(b.size())}, b);
  CHECK(test::allclose(gpu::download_vector<float>(ctx, y1, a.size()), nn::cpu::silu(ta).data, 1e-6, 1e-6, "silu"));
  CHECK(test::allclose(gpu::download_vector<float>(ctx, y2, a.size()), nn::cpu::add(ta, tb).data, 0.0, 0.0, "add"));
  // GELU alone: erf to ~3e-7 absolute, times |x| / 2.
  CHECK(test::allclose(gpu::download_vector<float>(ctx, y4, a.size()), nn::cpu::gelu(ta).data, 2e-6, 2e-6, "gelu"));
  CHECK(test::allclose(gpu::download_vector<float>(ctx, y5, a.size()), nn::cpu::relu(ta).data, 0.0, 0.0, "relu"));
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

TEST_CASE("nn elementwise cpu: GELU and SiLU at known values") {
  CHECK(nn::cpu::gelu(nn::CpuTensor({1}, 1.0f)).data[0] == doctest::Approx(0.8413447460685429));
  CHECK(nn::cpu::silu(nn::CpuTensor({1}, -1.0f)).data[0] == doctest::Approx(-0.2689414213699951));
}
