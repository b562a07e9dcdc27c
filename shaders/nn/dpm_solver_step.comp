#version 460
#extension GL_GOOGLE_include_directive : require
// dpm_solver_step: one DPM-Solver++ step (Lu et al. 2022, the data-prediction
// multistep solver, 2M) on a v-prediction, one thread per latent element:
//   v   = cond (+ cfg_scale * (cond - uncond) with NN_DPM_FLAG_CFG)
//   x0  = alpha_t * x - sigma_t * v
//   out = c_x * x + c_0 * x0 (+ c_1 * x0_prev with NN_DPM_FLAG_SECOND_ORDER)
//   x0_out = x0 (the next step's x0_prev)
// The coefficients (first order: c_x = sigma_s / sigma_t, c_0 = alpha_s (1 - e^-h);
// second order adds the previous data prediction) come from the host
// (diffusion/dpm_solver.h). `precise` keeps the CPU reference's rounding.
// Host module: kernels/nn/dpm_solver_step.{h,cpp}; CPU reference: nn::cpu::dpm_solver_step.
// Tests: tests/nn/test_dpm_solver_step.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_DPM_GROUP) in;
layout(push_constant) uniform Push { DpmSolverStepParams p; };
layout(std430, binding = 0) readonly buffer X { float x_in[]; };
layout(std430, binding = 1) readonly buffer Cond { float v_cond[]; };
layout(std430, binding = 2) readonly buffer Uncond { float v_uncond[]; };
layout(std430, binding = 3) readonly buffer PrevX0 { float x0_prev[]; };
layout(std430, binding = 4) writeonly buffer Out { float x_out[]; };
layout(std430, binding = 5) writeonly buffer X0Out { float x0_out[]; };

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  if (t >= p.count) return;
  const uint i = p.offset + t;  // one window of the latent (the same offset in every binding)
  const float x = x_in[i];
  precise float v = v_cond[i];
  if ((p.flags & NN_DPM_FLAG_CFG) != 0u) v = v + p.cfg_scale * (v - v_uncond[i]);
  precise const float x0 = p.alpha_t * x - p.sigma_t * v;
  precise float y = p.c_x * x + p.c_0 * x0;
  if ((p.flags & NN_DPM_FLAG_SECOND_ORDER) != 0u) y = y + p.c_1 * x0_prev[i];
  x_out[i] = y;
  x0_out[i] = x0;
}
