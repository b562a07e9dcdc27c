// DPM-Solver++ (2M) (engine/diffusion/dpm_solver.h) and the chunk sampler with it:
// a first-order step is DDIM's eta-0 step; on Gaussian data, whose exact
// denoiser and probability-flow ODE solution are known in closed form, the
// solver (on log-SNR-uniform timesteps) converges at second order and beats
// DDIM at every step count, at 20 steps DDIM-100; an oracle that knows x0 brings the latent to
// it; the GPU step gives the CPU's latent; eta != 0 is refused.
#include <doctest/doctest.h>

#include "diffusion/chunk_sampler.h"
#include "diffusion/dpm_solver.h"
#include "gpu_test_context.h"
#include "nn/random_vector.h"

#include <cmath>
#include <cstdio>

using namespace icube;
using namespace icube::diffusion;

namespace {

constexpr int64_t kC = 2, kX = 3, kY = 4, kZ = 5, kS = kX * kY * kZ;

// Data x0 ~ N(0, s^2) per element, the exact v-prediction: E[x0 | x_t] = alpha s^2 x / (alpha^2 s^2 + sigma^2),
// v = (alpha x - x0_hat) / sigma. Optionally an oracle of a fixed x0 instead.
struct GaussianDenoiser : Denoiser {
  double s = 1.0;
  std::vector<float> alphas;
  std::vector<float> fixed_x0;  // non-empty: predict this x0
  nn::CpuTensor predict(const nn::CpuTensor& x_in, int t) override {
    const int64_t B = x_in.shape[0];
    nn::CpuTensor v({B, kC, kX, kY, kZ});
    const double a = alphas[static_cast<size_t>(t)], alpha = std::sqrt(a), sigma = std::sqrt(1.0 - a);
    for (int64_t b = 0; b < B; ++b)
      for (int64_t i = 0; i < kC * kS; ++i) {
        const double x = x_in.data[static_cast<size_t>(b * (kC + 8) * kS + i)];
        const double x0 = fixed_x0.empty() ? alpha * s * s * x / (a * s * s + sigma * sigma)
                                           : double{fixed_x0[static_cast<size_t>(i)]};
        v.data[static_cast<size_t>(b * kC * kS + i)] = static_cast<float>((alpha * x - x0) / sigma);
      }
    return v;
  }
};

GaussianDenoiser gaussian(double s) {
  GaussianDenoiser g;
  g.s = s;
  DdimOptions o;
  g.alphas = DdimSchedule(o).alphas_cumprod();
  return g;
}

// max |x - exact| over the chunk: the ODE's solution from the first timestep t0 maps x to
// s x / sqrt(a_t0 s^2 + 1 - a_t0) at alpha = 1.
double ode_error(SamplerKind kind, int steps, double s) {
  GaussianDenoiser g = gaussian(s);
  SamplerOptions o;
  o.kind = kind;
  o.ddim.steps = steps;
  o.ddim.eta = 0.0f;
  o.seed = 3;
  const nn::CpuTensor cond({8, kX, kY, kZ});
  // The first input is the initial noise: record it through a wrapper.
  struct Recorder : Denoiser {
    GaussianDenoiser* inner;
    std::vector<float> first;
    int t0 = -1;
    nn::CpuTensor predict(const nn::CpuTensor& x_in, int t) override {
      if (first.empty()) {
        first.assign(x_in.data.begin(), x_in.data.begin() + kC * kS);
        t0 = t;
      }
      return inner->predict(x_in, t);
    }
  } rec;
  rec.inner = &g;
  const ChunkSample out = sample_chunk(rec, kC, cond, nullptr, 0, o);
  const double a0 = g.alphas[static_cast<size_t>(rec.t0)];
  const double gain = s / std::sqrt(a0 * s * s + 1.0 - a0);
  double err = 0;
  for (size_t i = 0; i < rec.first.size(); ++i)
    err = std::max(err, std::abs(double{out.latent.data[i]} - gain * double{rec.first[i]}));
  return err;
}

}  // namespace

TEST_CASE("dpm solver: a first-order step is DDIM's eta-0 step") {
  DdimOptions o;
  o.steps = 50;
  o.eta = 0.0f;
  const DdimSchedule sched(o);
  const size_t n = 257;
  const std::vector<float> x = test::random_vector(n, 1.0f, 5), v = test::random_vector(n, 1.0f, 6);
  for (const size_t i : {size_t{0}, size_t{49}}) {
    CAPTURE(i);
    const kernels::nn::DpmSolverStepCoefficients c = dpm_solver_coefficients(sched, i);
    CHECK_FALSE(c.second_order());
    std::vector<float> dpm(n), ddim(n);
    nn::cpu::dpm_solver_step(c, x.data(), v.data(), nullptr, dpm.data(), nullptr, n);
    nn::cpu::ddim_step(sched.step(i).coefficients(), x.data(), v.data(), nullptr, ddim.data(), n);
    CHECK(test::allclose(dpm, ddim, 2e-6, 2e-5, "dpm first order vs ddim"));
  }
  // The last step goes to alpha = 1: the data prediction itself.
  const kernels::nn::DpmSolverStepCoefficients last = dpm_solver_coefficients(sched, 49);
  CHECK(last.c_x == 0.0f);
  CHECK(last.c_0 == 1.0f);
  // In between: second order, the two data-prediction weights summing to alpha_s (1 - e^-h) as first order's.
  const kernels::nn::DpmSolverStepCoefficients mid = dpm_solver_coefficients(sched, 20);
  REQUIRE(mid.second_order());
  const DdimStep st = sched.step(20);
  const double a_s = st.alpha_prev, a_t = st.alpha;
  const double h = 0.5 * (std::log(a_s / (1.0 - a_s)) - std::log(a_t / (1.0 - a_t)));
  CHECK(double{mid.c_0} + double{mid.c_1} == doctest::Approx(std::sqrt(a_s) * -std::expm1(-h)).epsilon(1e-6));
}

TEST_CASE("dpm solver: log-SNR spacing gives distinct timesteps from T - 1 to 0 at equal steps in lambda") {
  for (const int steps : {1, 2, 10, 100, 500, 1000}) {
    CAPTURE(steps);
    DdimOptions o;
    o.steps = steps;
    o.spacing = TimestepSpacing::kLogSnr;
    const DdimSchedule sched(o);
    const std::vector<int>& ts = sched.timesteps();
    REQUIRE(ts.size() == static_cast<size_t>(steps));
    CHECK(ts.front() == 999);
    if (steps > 1) CHECK(ts.back() == 0);
    for (size_t i = 1; i < ts.size(); ++i) CHECK(ts[i] < ts[i - 1]);
    CHECK(sched.step(ts.size() - 1).alpha_prev == 1.0f);
    if (steps == 10) {  // equal h (to the rounding of t): lambda(T-1) = -5.1 .. lambda(0) = 4.6
      auto lambda = [&](int t) {
        const double a = sched.alphas_cumprod()[static_cast<size_t>(t)];
        return 0.5 * std::log(a / (1.0 - a));
      };
      for (size_t i = 1; i < ts.size(); ++i) CHECK(lambda(ts[i]) - lambda(ts[i - 1]) == doctest::Approx(1.08).epsilon(0.25));
    }
  }
}

TEST_CASE("dpm solver: second-order convergence on Gaussian data, ahead of DDIM at every step count") {
  // Data of std 0.5, 1 and 2. DPM-Solver++ on log-SNR steps against DDIM on the official leading steps;
  // each against the exact solution from its own first timestep.
  for (const double s : {0.5, 1.0, 2.0}) {
    CAPTURE(s);
    double prev_dpm = 0;
    for (const int steps : {10, 20, 40, 80}) {
      const double dpm = ode_error(SamplerKind::kDpmSolver2M, steps, s), ddim = ode_error(SamplerKind::kDdim, steps, s);
      std::printf("  gaussian s=%.1f, %3d steps: dpm++2m %.3e, ddim %.3e\n", s, steps, dpm, ddim);
      CAPTURE(steps);
      CHECK(dpm < ddim);
      // Second order: 4 per doubling once asymptotic (from 20 steps), above 2 from 10 to 20.
      if (prev_dpm > 0) CHECK(prev_dpm / dpm > (steps == 20 ? 2.0 : 3.5));
      prev_dpm = dpm;
    }
    if (s <= 1.0) CHECK(ode_error(SamplerKind::kDpmSolver2M, 20, s) < ode_error(SamplerKind::kDdim, 100, s));
  }
}

TEST_CASE("dpm solver: the sampler with an oracle of x0, on the CPU and the GPU, and eta refused") {
  GaussianDenoiser g = gaussian(1.0);
  g.fixed_x0 = test::random_vector(kC * kS, 1.0f, 9);
  const nn::CpuTensor cond({8, kX, kY, kZ});
  SamplerOptions o;
  o.kind = SamplerKind::kDpmSolver2M;
  o.ddim.eta = 0.0f;
  o.cfg_scale = 2.0f;  // both batch elements predict the same x0: guidance leaves it
  o.seed = 4;
  for (const int steps : {1, 2, 15, 100}) {
    CAPTURE(steps);
    o.ddim.steps = steps;
    const ChunkSample cpu = sample_chunk(g, kC, cond, nullptr, 3, o);
    const ChunkSample gpu = sample_chunk(g, kC, cond, nullptr, 3, o, &test::gpu_context());
    CHECK(test::allclose(cpu.latent.data, g.fixed_x0, 2e-4, 0.0, "dpm oracle"));
    CHECK(test::allclose(gpu.latent.data, cpu.latent.data, 1e-5, 1e-5, "dpm gpu vs cpu"));
  }
  o.ddim.eta = 1.0f;
  CHECK_THROWS_WITH_AS(sample_chunk(g, kC, cond, nullptr, 3, o), doctest::Contains("dpm++2m is deterministic"),
                       std::invalid_argument);
  CHECK_THROWS_AS(check_sampler_options(o), std::invalid_argument);
}
