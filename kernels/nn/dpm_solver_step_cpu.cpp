// The DPM-Solver++ step's CPU reference; see dpm_solver_step.h.
#include "kernels/nn/dpm_solver_step.h"

namespace icube::nn::cpu {

void dpm_solver_step(const kernels::nn::DpmSolverStepCoefficients& c, const float* x, const float* v,
                     const float* x0_prev, float* out, float* x0_out, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    const float x0 = c.alpha_t * x[i] - c.sigma_t * v[i];
    float y = c.c_x * x[i] + c.c_0 * x0;
    if (c.second_order()) y = y + c.c_1 * x0_prev[i];
    out[i] = y;
    if (x0_out) x0_out[i] = x0;
  }
}

}  // namespace icube::nn::cpu
