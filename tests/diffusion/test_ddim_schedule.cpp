// The DDIM schedule and step (engine/diffusion/ddim_schedule.h): betas and
// alphas_cumprod bit-equal to torch's float32 linspace + cumprod (FNV-1a
// checksums of the float bits, taken from python3-torch 1.13), the leading
// timesteps, one step against its closed form in double for eta 0 and 1 at
// both ends of the schedule (t = 999 and the last step to alpha_prev = 1),
// CFG, bad options, and how far a float64 schedule would be.
#include <doctest/doctest.h>

#include "diffusion/ddim_schedule.h"

#include <cmath>
#include <cstring>
#include <stdexcept>

using namespace icube::diffusion;

namespace {

uint64_t fnv1a_bits(const std::vector<float>& v) {
  uint64_t h = 0xcbf29ce484222325ull;
  for (const float f : v) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    h ^= u;
    h *= 0x100000001b3ull;
  }
  return h;
}

}  // namespace

TEST_CASE("ddim: betas and alphas_cumprod bit-equal to torch.linspace(float32) and torch.cumprod") {
  struct Case {
    int n;
    float start, end;
    uint64_t betas, alphas;
  };
  const Case cases[] = {{1000, 1e-4f, 0.02f, 0xbc53b83782d9c1faull, 0x111e4f057331bd53ull},
                        {1000, 0.00085f, 0.012f, 0xa58c15c3ef61d7faull, 0x9157c85a9094e50bull},
                        {999, 1e-4f, 0.02f, 0xe6e7e34c6bb157b6ull, 0x28074aa030ca6738ull},
                        {10, 0.1f, 0.2f, 0x8b72633f639d2c75ull, 0x5c246714e5b09d0aull},
                        {1001, 0.3f, 0.001f, 0x3ced996e9d600a7cull, 0x50d3f6840fcade92ull}};  // descending, odd tail
  for (const Case& c : cases) {
    CAPTURE(c.n);
    CAPTURE(c.start);
    const std::vector<float> b = linear_betas(c.n, c.start, c.end);
    CHECK(b.front() == c.start);
    CHECK(b.back() == c.end);
    CHECK(fnv1a_bits(b) == c.betas);
    CHECK(fnv1a_bits(alphas_cumprod(b)) == c.alphas);
  }
  const DdimSchedule s({});
  CHECK(s.alphas_cumprod()[0] == 0.9998999834060669f);
  CHECK(s.alphas_cumprod()[500] == 0.07779666036367416f);
  CHECK(s.alphas_cumprod()[999] == 4.0358307160204276e-05f);
}

TEST_CASE("ddim: a float64 schedule would differ by 3.5e-7 in alpha and 8.3e-5 in sqrt(1 - alpha) near t = 0") {
  const DdimSchedule s({});
  double max_alpha = 0.0, max_beta = 0.0, acc = 1.0;
  for (int t = 0; t < 1000; ++t) {
    acc *= 1.0 - (1e-4 + (0.02 - 1e-4) * t / 999.0);
    const double a32 = s.alphas_cumprod()[static_cast<size_t>(t)];
    max_alpha = std::max(max_alpha, std::abs(a32 - acc) / acc);
    max_beta = std::max(max_beta, std::abs(std::sqrt(1.0 - a32) - std::sqrt(1.0 - acc)) / std::sqrt(1.0 - acc));
  }
  MESSAGE("float32 vs float64 schedule: alpha ", max_alpha, ", sqrt(1 - alpha) ", max_beta, " (relative)");
  CHECK(max_alpha < 5e-7);
  CHECK(max_beta < 1e-4);
  CHECK(max_beta > 1e-5);  // the float32 rounding of alpha near 1 is what the reference carries
}

TEST_CASE("ddim: leading timesteps, steps_offset, the step after the last") {
  DdimOptions o;
  CHECK(DdimSchedule(o).timesteps().front() == 990);
  CHECK(DdimSchedule(o).timesteps().back() == 0);
  CHECK(DdimSchedule(o).size() == 100);
  o.steps = 30;  // 1000 // 30 = 33: 957, 924, ..., 0
  const DdimSchedule s30(o);
  CHECK(s30.timesteps().front() == 957);
  CHECK(s30.timesteps()[1] == 924);
  CHECK(s30.step(0).t_prev == 924);
  o.steps = 1000;
  const DdimSchedule all(o);
  CHECK(all.timesteps().front() == 999);
  o.steps = 10;
  o.steps_offset = 1;
  CHECK(DdimSchedule(o).timesteps().front() == 901);
  CHECK(DdimSchedule(o).timesteps().back() == 1);
  o.steps_offset = 0;
  o.steps = 1;
  const DdimStep only = DdimSchedule(o).step(0);
  CHECK(only.t == 0);
  CHECK(only.alpha_prev == 1.0f);
  o.steps = 0;
  CHECK_THROWS_WITH_AS(DdimSchedule{o}, doctest::Contains("--steps 0 is not in 1..1000"), std::invalid_argument);
  o.steps = 10;
  o.eta = -0.5f;
  CHECK_THROWS_WITH_AS(DdimSchedule{o}, doctest::Contains("--eta"), std::invalid_argument);
  o.eta = std::nanf("");
  CHECK_THROWS_AS(DdimSchedule{o}, std::invalid_argument);
}

TEST_CASE("ddim: one step against its closed form, eta 0 and 1, at t = 999 and at the last step") {
  for (const float eta : {0.0f, 1.0f}) {
    for (const int steps : {1000, 100, 10}) {
      DdimOptions o;
      o.eta = eta;
      o.steps = steps;
      const DdimSchedule s(o);
      for (const size_t i : {size_t{0}, s.size() / 2, s.size() - 1}) {
        CAPTURE(eta);
        CAPTURE(steps);
        CAPTURE(i);
        const DdimStep st = s.step(i);
        const double a = st.alpha, ap = st.alpha_prev;
        const double sigma = double{eta} * std::sqrt((1 - ap) / (1 - a) * (1 - a / ap));
        CHECK(double{st.sigma} == doctest::Approx(sigma).epsilon(1e-5));
        const float x[3] = {0.7f, -1.3f, 2.0f}, v[3] = {-0.2f, 0.9f, 0.0f}, z[3] = {1.1f, 0.3f, -2.5f};
        float out[3];
        icube::nn::cpu::ddim_step(st.coefficients(), x, v, z, out, 3);
        for (int k = 0; k < 3; ++k) {
          const double xk = x[k], vk = v[k], zk = z[k];
          const double x0 = std::sqrt(a) * xk - std::sqrt(1 - a) * vk;
          const double eps = std::sqrt(a) * vk + std::sqrt(1 - a) * xk;
          const double want = std::sqrt(ap) * x0 + std::sqrt(std::max(0.0, 1 - ap - sigma * sigma)) * eps + sigma * zk;
          CHECK(double{out[k]} == doctest::Approx(want).epsilon(2e-5).scale(1.0));
        }
        if (i + 1 == s.size()) {  // to alpha_prev = 1: x0 exactly, no noise
          CHECK(st.alpha_prev == 1.0f);
          CHECK(st.sigma == 0.0f);
          CHECK(st.direction == 0.0f);
        }
      }
    }
  }
  // t = 999 with 1000 steps: the first step of the finest schedule.
  DdimOptions o;
  o.steps = 1000;
  const DdimStep first = DdimSchedule(o).step(0);
  CHECK(first.t == 999);
  CHECK(first.t_prev == 998);
}

TEST_CASE("ddim: classifier-free guidance is cond + s (cond - uncond); s = 0 is the conditional pass") {
  const float cond[3] = {1.0f, -2.0f, 0.5f}, uncond[3] = {0.5f, -1.0f, 0.5f};
  float out[3];
  icube::nn::cpu::cfg_combine(cond, uncond, 2.0f, out, 3);
  CHECK(out[0] == 2.0f);
  CHECK(out[1] == -4.0f);
  CHECK(out[2] == 0.5f);
  icube::nn::cpu::cfg_combine(cond, uncond, 0.0f, out, 3);
  CHECK(out[1] == -2.0f);
}
