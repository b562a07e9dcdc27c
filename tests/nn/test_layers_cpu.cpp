// The plain CPU layer references (engine/nn/layers_cpu.h) on cases with known
// answers: a conv3d against an independent per-output formula at odd sizes,
// stride 2 and 1x1 kernels; GroupNorm of a constant input (the bias) and of a
// ramp; softmax of huge logits; pooling and upsampling; GEGLU's GELU; the
// sinusoidal embedding's [cos | sin] order.
#include <doctest/doctest.h>

#include "nn/layers_cpu.h"

#include <cmath>
#include <random>

using namespace icube::nn;

namespace {

CpuTensor random_tensor(std::vector<int64_t> shape, uint32_t seed, float scale = 1.0f) {
  CpuTensor t(std::move(shape));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-scale, scale);
  for (float& v : t.data) v = u(rng);
  return t;
}

}  // namespace

TEST_CASE("nn cpu: conv3d equals the per-output definition (odd sizes, padding, stride 2, 1x1)") {
  const CpuTensor x = random_tensor({2, 3, 5, 4, 7}, 1);
  const CpuTensor w = random_tensor({4, 3, 3, 3, 3}, 2);
  const CpuTensor b = random_tensor({4}, 3);
  for (const int stride : {1, 2}) {
    const CpuTensor y = cpu::conv3d(x, w, &b, stride, 1);
    const int64_t OX = (5 + 2 - 3) / stride + 1, OY = (4 + 2 - 3) / stride + 1, OZ = (7 + 2 - 3) / stride + 1;
    REQUIRE(y.shape == std::vector<int64_t>{2, 4, OX, OY, OZ});
    double worst = 0.0;
    for (int64_t n = 0; n < 2; ++n)
      for (int64_t o = 0; o < 4; ++o)
        for (int64_t i = 0; i < OX; ++i)
          for (int64_t j = 0; j < OY; ++j)
            for (int64_t k = 0; k < OZ; ++k) {
              long double s = b.data[static_cast<size_t>(o)];
              for (int64_t c = 0; c < 3; ++c)
                for (int64_t a = 0; a < 3; ++a)
                  for (int64_t e = 0; e < 3; ++e)
                    for (int64_t f = 0; f < 3; ++f) {
                      const int64_t xi = i * stride - 1 + a, yj = j * stride - 1 + e, zk = k * stride - 1 + f;
                      if (xi < 0 || xi >= 5 || yj < 0 || yj >= 4 || zk < 0 || zk >= 7) continue;
                      s += static_cast<long double>(w.data[static_cast<size_t>((((o * 3 + c) * 3 + a) * 3 + e) * 3 + f)]) *
                           x.data[static_cast<size_t>((((n * 3 + c) * 5 + xi) * 4 + yj) * 7 + zk)];
                    }
              const float got = y.data[static_cast<size_t>((((n * 4 + o) * OX + i) * OY + j) * OZ + k)];
              worst = std::max(worst, std::abs(static_cast<double>(got) - static_cast<double>(s)));
            }
    CHECK(worst < 1e-6);
  }
  // 1x1: the same as a channel matrix product.
  const CpuTensor w1 = random_tensor({2, 3, 1, 1, 1}, 4);
  const CpuTensor y1 = cpu::conv3d(x, w1, nullptr, 1, 0);
  const size_t S = 5 * 4 * 7;
  const float want = w1.data[3] * x.data[S * 3 + 10] + w1.data[4] * x.data[S * 4 + 10] + w1.data[5] * x.data[S * 5 + 10];
  CHECK(y1.data[S * 3 + 10] == doctest::Approx(want).epsilon(1e-6));
  CHECK_THROWS_AS(cpu::conv3d(x, random_tensor({4, 2, 3, 3, 3}, 5), nullptr), std::invalid_argument);
}

TEST_CASE("nn cpu: GroupNorm of a constant is its bias; statistics per group; huge values stay finite") {
  CpuTensor x({1, 64, 2, 3, 1}, 1e6f);
  CpuTensor w({64}, 3.0f), b({64}, 0.0f);
  for (int c = 0; c < 64; ++c) b.data[static_cast<size_t>(c)] = static_cast<float>(c);
  const CpuTensor y = cpu::group_norm(x, 32, w, b, 1e-5);
  for (int c = 0; c < 64; ++c) CHECK(y.data[static_cast<size_t>(c * 6)] == static_cast<float>(c));
  // A ramp within one group of two channels: mean and biased variance over 12 values.
  CpuTensor r({1, 2, 2, 3, 1});
  for (int i = 0; i < 12; ++i) r.data[static_cast<size_t>(i)] = static_cast<float>(i);
  const CpuTensor yr = cpu::group_norm(r, 1, CpuTensor({2}, 1.0f), CpuTensor({2}, 0.0f), 0.0);
  const double sd = std::sqrt((144.0 - 1.0) / 12.0);  // variance of 0..11
  CHECK(yr.data[0] == doctest::Approx(-5.5 / sd).epsilon(1e-6));
  CHECK(yr.data[11] == doctest::Approx(5.5 / sd).epsilon(1e-6));
  CHECK_THROWS_AS(cpu::group_norm(r, 3, CpuTensor({2}), CpuTensor({2}), 1e-5), std::invalid_argument);
}

TEST_CASE("nn cpu: attention with huge logits is a stable softmax; uniform keys average the values") {
  CpuTensor q({1, 1, 2, 2}, std::vector<float>{1e4f, 0.f, 0.f, 0.f});
  CpuTensor k({1, 1, 2, 2}, std::vector<float>{1e4f, 0.f, -1e4f, 0.f});
  CpuTensor v({1, 1, 2, 2}, std::vector<float>{1.f, 2.f, 3.f, 4.f});
  const CpuTensor o = cpu::attention(q, k, v);
  CHECK(o.data[0] == 1.0f);  // all weight on key 0
  CHECK(o.data[1] == 2.0f);
  CHECK(o.data[2] == 2.0f);  // query 1 is zero: equal weights, the mean of the values
  CHECK(o.data[3] == 3.0f);
}

TEST_CASE("nn cpu: pooling, upsampling, GELU, SiLU and the [cos | sin] timestep embedding") {
  CpuTensor x({1, 1, 2, 2, 3});
  for (int i = 0; i < 12; ++i) x.data[static_cast<size_t>(i)] = static_cast<float>(i);
  const CpuTensor p = cpu::avg_pool2(x);  // floors Z = 3 to 1
  REQUIRE(p.shape == std::vector<int64_t>{1, 1, 1, 1, 1});
  CHECK(p.data[0] == doctest::Approx((0 + 1 + 3 + 4 + 6 + 7 + 9 + 10) / 8.0));
  const CpuTensor u = cpu::upsample2(x);
  CHECK(u.shape == std::vector<int64_t>{1, 1, 4, 4, 6});
  CHECK(u.data[static_cast<size_t>((3 * 4 + 3) * 6 + 5)] == 11.0f);
  CHECK(cpu::gelu(CpuTensor({1}, 1.0f)).data[0] == doctest::Approx(0.8413447460685429));
  CHECK(cpu::silu(CpuTensor({1}, -1.0f)).data[0] == doctest::Approx(-0.2689414213699951));
  const CpuTensor e = cpu::timestep_embedding({0, 7}, 6);
  CHECK(e.data[0] == 1.0f);   // cos(0)
  CHECK(e.data[3] == 0.0f);   // sin(0)
  CHECK(e.data[6] == doctest::Approx(std::cos(7.0)));  // frequency 1 first
  CHECK(e.data[9] == doctest::Approx(std::sin(7.0)));
  CHECK(e.data[11] == doctest::Approx(std::sin(7.0 * std::exp(-std::log(10000.0) * 2.0 / 3.0))).epsilon(1e-5));
}
