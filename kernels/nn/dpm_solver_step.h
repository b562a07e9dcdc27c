// One DPM-Solver++ (2M) step of the sampler on the GPU (shaders/nn/dpm_solver_step.comp):
// a v-prediction with optional classifier-free guidance turned into the data
// prediction x0, the step a linear combination of x, x0 and the previous step's
// x0, float32 in the reference's operation order. The coefficients come from
// the caller (diffusion/dpm_solver.h computes them from the schedule); no
// barrier inside. A latent over one storage binding runs in windows of elements.
// CPU reference (below, dpm_solver_step_cpu.cpp): nn::cpu::dpm_solver_step.
// Tests: tests/nn/test_dpm_solver_step.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstddef>
#include <cstdint>

namespace icube::kernels::nn {

// x0 = alpha_t x - sigma_t v; out = c_x x + c_0 x0 + c_1 x0_prev (c_1 = 0: first order).
struct DpmSolverStepCoefficients {
  float alpha_t = 0, sigma_t = 0, c_x = 0, c_0 = 0, c_1 = 0;
  bool second_order() const { return c_1 != 0.0f; }
};

class DpmSolverStep {
 public:
  explicit DpmSolverStep(gpu::Context& ctx);
  // out = step(x, v), x0_out = the step's data prediction; v = cond + cfg_scale (cond - uncond) when uncond
  // is given; x0_prev is read by a second-order step (then required). out and x0_out may not alias the inputs.
  void record(gpu::CommandList& cmd, const DpmSolverStepCoefficients& c, uint64_t count, const gpu::Buffer& x,
              const gpu::Buffer& v_cond, const gpu::Buffer* v_uncond, float cfg_scale, const gpu::Buffer* x0_prev,
              const gpu::Buffer& out, const gpu::Buffer& x0_out);

  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// x0 = alpha_t x - sigma_t v; out = c_x x + c_0 x0 (+ c_1 x0_prev when second order); x0_out = x0 (may be
// null). n elements, float32 in this order; v already guided (cfg_combine).
void dpm_solver_step(const kernels::nn::DpmSolverStepCoefficients& c, const float* x, const float* v,
                     const float* x0_prev, float* out, float* x0_out, size_t n);

}  // namespace icube::nn::cpu
