// layer_norm: y[b, c, t] = (x[b, c, t] - mean_t) * rstd_t * w[c] + bias[c]
// with mean_t and the biased variance over the channels of token t
// (torch.nn.LayerNorm over the last axis of [b, t, c], here on the
// channels-first layout the UNet keeps). One thread per token; consecutive
// threads read consecutive tokens. fp32, Welford over the channels; the
// output fp32, or fp16 with NN_NORM_F16_OUTPUT (layer_norm_f16out.comp).
// Host module: kernels/nn/layer_norm.{h,cpp}. Tests: tests/nn/test_layer_norm.cpp.
#include "shared/nn_params.h"
#include "norm_output.glsl"
#include "common/dispatch.glsl"

layout(local_size_x = NN_LN_GROUP) in;
layout(push_constant) uniform Push { LayerNormParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) readonly buffer Weight { float ln_weight[]; };
layout(std430, binding = 2) readonly buffer Bias { float ln_bias[]; };
layout(std430, binding = 3) writeonly buffer Out { norm_store_t y_out[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.batch * p.tokens) return;
  const uint b = i / p.tokens, t = i % p.tokens;
  const uint base = b * p.channels * p.tokens + t;
  float mean = 0.0, m2 = 0.0;
  for (uint c = 0u; c < p.channels; ++c) {
    const float v = x_in[base + c * p.tokens];
    const float d = v - mean;
    mean += d / float(c + 1u);
    m2 += d * (v - mean);
  }
  const float rstd = inversesqrt(m2 / float(p.channels) + p.eps);
  for (uint c = 0u; c < p.channels; ++c)
    y_out[base + c * p.tokens] = norm_store_t((x_in[base + c * p.tokens] - mean) * rstd * ln_weight[c] + ln_bias[c]);
}
