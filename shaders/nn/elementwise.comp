#version 460
#extension GL_GOOGLE_include_directive : require
// elementwise: SiLU, GELU, ReLU, add, or GEGLU's gating (ElementwiseParams.op, see
// shared/nn_params.h), one thread per output element, float32. NN_EW_GEGLU reads
// both halves of each batch element from binding A; NN_EW_GATE_GELU, the same gating
// over windows, reads the value from A and the gate from B at the same index. GELU is the
// exact form x/2 (1 + erf(x/sqrt 2)) (F.gelu's default); GLSL has no erf, so
// erf_f evaluates its Taylor series below |x| = 2 and erfc's continued
// fraction above, to about 3e-7 absolute; far negative inputs use erfc
// directly, so gelu keeps its tiny values instead of cancelling to 0.
// Host module: kernels/nn/elementwise.{h,cpp}. Tests: tests/nn/test_elementwise.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_EW_GROUP) in;
layout(push_constant) uniform Push { ElementwiseParams p; };
layout(std430, binding = 0) readonly buffer A { float a_in[]; };
layout(std430, binding = 1) readonly buffer B { float b_in[]; };
layout(std430, binding = 2) writeonly buffer Out { float y_out[]; };

// erfc(a) for a >= 2 by its continued fraction (no cancellation).
float erfc_cf(float a) {
  float f = a;
  for (int k = 30; k >= 1; --k) f = a + (float(k) * 0.5) / f;
  return exp(-a * a) / (1.7724538509055159 * f);
}

// erf(x): Taylor series for |x| < 2 (terms until they vanish in float), 1 - erfc beyond.
float erf_f(float x) {
  const float ax = abs(x);
  float r;
  if (ax < 2.0) {
    // erf(x) = 2/sqrt(pi) * sum_n (-1)^n x^(2n+1) / (n! (2n+1))
    float term = ax, sum = ax;
    const float x2 = ax * ax;
    for (int n = 1; n < 40; ++n) {
      term *= -x2 / float(n);
      const float add = term / float(2 * n + 1);
      sum += add;
      if (abs(add) < 1e-9 * abs(sum)) break;
    }
    r = 1.1283791670955126 * sum;
  } else {
    // erfc(x) = exp(-x^2) / sqrt(pi) / (x + 1/2 / (x + 1 / (x + 3/2 / (x + 2 / (x + ...)))))
    r = 1.0 - erfc_cf(ax);
  }
  return x < 0.0 ? -r : r;
}

// gelu(g) = g/2 (1 + erf(g / sqrt 2)); for g / sqrt 2 <= -2 as g/2 erfc(|g| / sqrt 2), where 1 + erf cancels.
float gelu_f(float g) {
  const float z = g * 0.70710678118654752;
  return z <= -2.0 ? 0.5 * g * erfc_cf(-z) : 0.5 * g * (1.0 + erf_f(z));
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.count) return;
  if (p.op == NN_EW_SILU) {
    const float v = a_in[p.a_offset + i];
    y_out[p.y_offset + i] = v / (1.0 + exp(-v));
  } else if (p.op == NN_EW_ADD) {
    y_out[p.y_offset + i] = a_in[p.a_offset + i] + b_in[p.b_offset + i];
  } else if (p.op == NN_EW_GELU) {
    y_out[p.y_offset + i] = gelu_f(a_in[p.a_offset + i]);
  } else if (p.op == NN_EW_RELU) {
    y_out[p.y_offset + i] = max(a_in[p.a_offset + i], 0.0);
  } else if (p.op == NN_EW_GATE_GELU) {
    y_out[p.y_offset + i] = a_in[p.a_offset + i] * gelu_f(b_in[p.b_offset + i]);
  } else {
    const uint per_batch = p.channels * p.tokens;
    const uint b = i / per_batch, r = i % per_batch;
    const float value = a_in[p.a_offset + b * 2u * per_batch + r];
    const float gate = a_in[p.a_offset + b * 2u * per_batch + per_batch + r];
    y_out[p.y_offset + i] = value * gelu_f(gate);
  }
}
