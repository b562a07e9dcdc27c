#version 460
#extension GL_GOOGLE_include_directive : require
// batch_norm: inference BatchNorm folded to a per-channel affine, optionally
// fused with an activation: y = act(x * scale[c] + shift[c]) over [batch,
// channels, spatial] float32 (the GSM's conv encoder: BN+ReLU, BN+SiLU; the
// Depth-Anything upsampler's residual blocks), act = none, ReLU max(v, 0) or
// SiLU v / (1 + e^-v). One thread per element; it reads and then writes only
// its own element, so x and y may be the same buffer. A dispatch covers a flat
// window of `count` elements (BatchNormParams).
// Host module: kernels/nn/batch_norm.{h,cpp}; CPU reference: nn::cpu::batch_norm
// (kernels/nn/batch_norm.h). Tests: tests/nn/test_batch_norm.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_BN_GROUP) in;
layout(push_constant) uniform Push { BatchNormParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) readonly buffer Scale { float scale[]; };
layout(std430, binding = 2) readonly buffer Shift { float shift[]; };
layout(std430, binding = 3) writeonly buffer Out { float y_out[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.count) return;
  const uint c = (p.first_channel + (p.first_spatial + i) / p.spatial) % p.channels;
  float v = fma(x_in[p.x_offset + i], scale[c], shift[c]);
  if (p.activation == NN_BN_ACT_RELU) v = max(v, 0.0);
  else if (p.activation == NN_BN_ACT_SILU) v = v / (1.0 + exp(-v));
  y_out[p.y_offset + i] = v;
}
