#version 460
#extension GL_GOOGLE_include_directive : require
// ddim_step: one DDIM step on a v-prediction, one thread per latent element,
// float32 in the reference's operation order (nn::cpu::ddim_step in kernels/nn/ddim_step.h,
// conventions §9.1-9.2):
//   v   = cond (+ cfg_scale * (cond - uncond) with NN_DDIM_FLAG_CFG)
//   x0  = sqrt_alpha * x - sqrt_beta * v;   eps = sqrt_alpha * v + sqrt_beta * x
//   out = sqrt_alpha_prev * x0 + direction * eps (+ sigma * z with NN_DDIM_FLAG_NOISE)
// `precise` keeps every product and sum rounded as written (no contraction into
// fused multiply-adds), so the result is the CPU reference's on any device.
// Host module: kernels/nn/ddim_step.{h,cpp}. Tests: tests/nn/test_ddim_step.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_DDIM_GROUP) in;
layout(push_constant) uniform Push { DdimStepParams p; };
layout(std430, binding = 0) readonly buffer X { float x_in[]; };
layout(std430, binding = 1) readonly buffer Cond { float v_cond[]; };
layout(std430, binding = 2) readonly buffer Uncond { float v_uncond[]; };
layout(std430, binding = 3) readonly buffer Noise { float z_in[]; };
layout(std430, binding = 4) writeonly buffer Out { float x_out[]; };

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  if (t >= p.count) return;
  const uint i = p.offset + t;  // one window of the latent (the same offset in every binding)
  const float x = x_in[i];
  precise float v = v_cond[i];
  if ((p.flags & NN_DDIM_FLAG_CFG) != 0u) v = v + p.cfg_scale * (v - v_uncond[i]);
  precise const float x0 = p.sqrt_alpha * x - p.sqrt_beta * v;
  precise const float eps = p.sqrt_alpha * v + p.sqrt_beta * x;
  precise float y = p.sqrt_alpha_prev * x0 + p.direction * eps;
  if ((p.flags & NN_DDIM_FLAG_NOISE) != 0u) y = y + p.sigma * z_in[i];
  x_out[i] = y;
}
