// The DDIM step's CPU references; see ddim_step.h.
#include "kernels/nn/ddim_step.h"

namespace icube::nn::cpu {

void ddim_step(const kernels::nn::DdimStepCoefficients& s, const float* x, const float* v, const float* z, float* out,
               size_t n) {
  for (size_t i = 0; i < n; ++i) {
    const float x0 = s.sqrt_alpha * x[i] - s.sqrt_beta * v[i];
    const float eps = s.sqrt_alpha * v[i] + s.sqrt_beta * x[i];
    float y = s.sqrt_alpha_prev * x0 + s.direction * eps;
    if (s.sigma != 0.0f) y = y + s.sigma * z[i];
    out[i] = y;
  }
}

void cfg_combine(const float* cond, const float* uncond, float scale, float* out, size_t n) {
  for (size_t i = 0; i < n; ++i) out[i] = cond[i] + scale * (cond[i] - uncond[i]);
}

}  // namespace icube::nn::cpu
