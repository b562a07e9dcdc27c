// The DPM-Solver++ step on the GPU (kernels/nn/dpm_solver_step.h,
// shaders/nn/dpm_solver_step.comp) against the CPU reference
// (nn::cpu::cfg_combine + dpm_solver_step): odd sizes, first and second order,
// both ends of the schedule (t = 990 and the last step to alpha = 1), guidance
// 1, 2 and 10, large latents, windows over a capped binding, and the refusal
// of a second-order step without the previous data prediction. Runs under the
// validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "diffusion/dpm_solver.h"
#include "gpu_test_context.h"
#include "kernels/nn/dpm_solver_step.h"
#include "nn/random_vector.h"

using namespace icube;

using test::random_vector;

namespace {

void check_step(gpu::Context& ctx, const kernels::nn::DpmSolverStepCoefficients& c, size_t n, float cfg, float scale,
                uint64_t max_binding_bytes = 0) {
  const std::vector<float> x = random_vector(n, scale, 1), vc = random_vector(n, 1.0f, 2), vu = random_vector(n, 1.0f, 3),
                           x0_prev = random_vector(n, 1.0f, 4);
  std::vector<float> v = vc, want(n), want_x0(n);
  if (cfg != 1.0f) nn::cpu::cfg_combine(vc.data(), vu.data(), cfg, v.data(), n);
  nn::cpu::dpm_solver_step(c, x.data(), v.data(), x0_prev.data(), want.data(), want_x0.data(), n);
  gpu::Buffer xb = gpu::upload_vector(ctx, x, "x"), cb = gpu::upload_vector(ctx, vc, "cond"),
              ub = gpu::upload_vector(ctx, vu, "uncond"), pb = gpu::upload_vector(ctx, x0_prev, "x0 prev");
  gpu::Buffer out(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "out"), x0(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "x0");
  kernels::nn::DpmSolverStep step(ctx);
  step.set_max_binding_bytes(max_binding_bytes);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    step.record(cmd, c, n, xb, cb, cfg != 1.0f ? &ub : nullptr, cfg, c.second_order() ? &pb : nullptr, out, x0);
  });
  CHECK(test::allclose(gpu::download_vector<float>(ctx, out, n), want, 1e-6 * double{scale}, 2e-6, "dpm_solver_step"));
  CHECK(test::allclose(gpu::download_vector<float>(ctx, x0, n), want_x0, 1e-6 * double{scale}, 2e-6, "dpm_solver_step x0"));
}

}  // namespace

TEST_CASE("dpm solver step gpu: first and second order with guidance match the CPU reference") {
  gpu::Context& ctx = test::gpu_context();
  diffusion::DdimOptions o;
  o.steps = 100;
  o.eta = 0.0f;
  const diffusion::DdimSchedule sched(o);
  for (const size_t n : {size_t{1}, size_t{1001}, size_t{8 * 17 * 9 * 5}})
    for (const size_t i : {size_t{0}, size_t{1}, size_t{50}, sched.size() - 2, sched.size() - 1})
      for (const float cfg : {1.0f, 2.0f, 10.0f}) {
        CAPTURE(n);
        CAPTURE(i);
        CAPTURE(cfg);
        const kernels::nn::DpmSolverStepCoefficients c = diffusion::dpm_solver_coefficients(sched, i);
        CHECK(c.second_order() == (i > 0 && i + 1 < sched.size()));
        check_step(ctx, c, n, cfg, i == 0 ? 1.0f : 300.0f);
      }
}

TEST_CASE("dpm solver step gpu: a latent over a capped binding runs in windows") {
  diffusion::DdimOptions o;
  o.eta = 0.0f;
  const diffusion::DdimSchedule sched(o);
  // 1,000 elements over 400-byte and 1,600-byte bindings: windows at offsets that are not aligned.
  check_step(test::gpu_context(), diffusion::dpm_solver_coefficients(sched, 7), 1000, 2.0f, 1.0f, 400);
  check_step(test::gpu_context(), diffusion::dpm_solver_coefficients(sched, 7), 1000, 1.0f, 1.0f, 1600);
  check_step(test::capped_gpu_context(16u << 10), diffusion::dpm_solver_coefficients(sched, 8), 9000, 2.0f, 1.0f);
}

TEST_CASE("dpm solver step gpu: a second-order step without the previous data prediction is refused") {
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::DpmSolverStep step(ctx);
  gpu::Buffer b(ctx, 64);
  kernels::nn::DpmSolverStepCoefficients c{0.5f, 0.8f, 1.0f, 0.3f, -0.1f};
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(step.record(cmd, c, 16, b, b, nullptr, 1.0f, nullptr, b, b),
                         doctest::Contains("without the previous data prediction"), std::invalid_argument);
  });
}
