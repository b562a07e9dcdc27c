// The DDIM step on the GPU (kernels/nn/ddim_step.h, shaders/nn/ddim_step.comp)
// against the CPU reference (nn::cpu::cfg_combine + ddim_step): odd sizes,
// both ends of the schedule (t = 999, the last step to alpha_prev = 1), eta 0
// and 1, guidance 2 and 10, large latents. Runs under the validation layer.
#include <doctest/doctest.h>

#include "diffusion/ddim_schedule.h"
#include "gpu_test_context.h"
#include "nn/random_vector.h"
#include "kernels/nn/ddim_step.h"

#include <random>

using namespace icube;

using test::random_vector;

TEST_CASE("ddim step gpu: the DDIM step with guidance and noise matches the CPU reference") {
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::DdimStep sampler(ctx);
  for (const size_t n : {size_t{1}, size_t{1001}, size_t{8 * 17 * 9 * 5}}) {
    for (const float eta : {0.0f, 1.0f}) {
      diffusion::DdimOptions o;
      o.steps = 1000;
      o.eta = eta;
      const diffusion::DdimSchedule sched(o);
      for (const size_t i : {size_t{0}, size_t{500}, sched.size() - 1}) {
        for (const float cfg : {1.0f, 2.0f, 10.0f}) {
          CAPTURE(n);
          CAPTURE(eta);
          CAPTURE(i);
          CAPTURE(cfg);
          const diffusion::DdimStep st = sched.step(i);
          const float scale = i == 0 ? 1.0f : 300.0f;  // large latents at the last steps
          const std::vector<float> x = random_vector(n, scale, 1), vc = random_vector(n, 1.0f, 2), vu = random_vector(n, 1.0f, 3),
                                   z = random_vector(n, 1.0f, 4);
          std::vector<float> v = vc, want(n);
          if (cfg != 1.0f) nn::cpu::cfg_combine(vc.data(), vu.data(), cfg, v.data(), n);
          nn::cpu::ddim_step(st.coefficients(), x.data(), v.data(), z.data(), want.data(), n);
          gpu::Buffer xb = gpu::upload_vector(ctx, x, "x"), cb = gpu::upload_vector(ctx, vc, "cond"),
                      ub = gpu::upload_vector(ctx, vu, "uncond"), zb = gpu::upload_vector(ctx, z, "z");
          gpu::Buffer out(ctx, n * 4, gpu::MemoryUsage::DeviceLocal, "out");
          const kernels::nn::DdimStepCoefficients c{st.sqrt_alpha, st.sqrt_beta, st.sqrt_alpha_prev, st.direction, st.sigma};
          ctx.submit_and_wait([&](gpu::CommandList& cmd) {
            sampler.record(cmd, c, n, xb, cb, cfg != 1.0f ? &ub : nullptr, cfg, st.sigma != 0.0f ? &zb : nullptr, out);
          });
          CHECK(test::allclose(gpu::download_vector<float>(ctx, out, n), want, 1e-6 * double{scale}, 2e-6, "ddim_step"));
        }
      }
    }
  }
  // sigma > 0 without noise: refused.
  diffusion::DdimOptions o;
  const diffusion::DdimStep st = diffusion::DdimSchedule(o).step(3);
  REQUIRE(st.sigma > 0.0f);
  gpu::Buffer b(ctx, 64);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(sampler.record(cmd, {st.sqrt_alpha, st.sqrt_beta, st.sqrt_alpha_prev, st.direction, st.sigma}, 16, b, b,
                                      nullptr, 1.0f, nullptr, b),
                         doctest::Contains("without a noise buffer"), std::invalid_argument);
  });
}

TEST_CASE("ddim step gpu: a latent over one storage binding runs in element windows, bit for bit") {
  // Bindings of 400 bytes: 1001 elements in windows of ~96 (odd size, unaligned window ends), guidance and
  // noise on; the same bytes as one dispatch.
  gpu::Context& ctx = test::gpu_context();
  const size_t n = 1001;
  diffusion::DdimOptions o;
  const diffusion::DdimStep st = diffusion::DdimSchedule(o).step(5);
  REQUIRE(st.sigma > 0.0f);
  const std::vector<float> x = random_vector(n, 1.0f, 1), vc = random_vector(n, 1.0f, 2), vu = random_vector(n, 1.0f, 3),
                           z = random_vector(n, 1.0f, 4);
  gpu::Buffer xb = gpu::upload_vector(ctx, x), cb = gpu::upload_vector(ctx, vc), ub = gpu::upload_vector(ctx, vu),
              zb = gpu::upload_vector(ctx, z), whole(ctx, n * 4), windowed(ctx, n * 4);
  for (const uint64_t cap : {uint64_t{0}, uint64_t{400}}) {
    kernels::nn::DdimStep step(ctx);
    step.set_max_binding_bytes(cap);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      step.record(cmd, st.coefficients(), n, xb, cb, &ub, 2.0f, &zb, cap ? windowed : whole);
    });
  }
  CHECK(gpu::download_vector<float>(ctx, windowed, n) == gpu::download_vector<float>(ctx, whole, n));
}
