#version 460
#extension GL_GOOGLE_include_directive : require
// rms_norm: x-unet's RMSNorm over the channels of [batch, channels, plane]
// float32, y[b, c, s] = x[b, c, s] * (scale / max(n, eps)) * gamma[c] with n =
// |x[b, :, s]|_2 and scale = sqrt(channels), then y / (1 + e^-y) with
// NN_RMS_FLAG_SILU (x-unet's Block). One invocation per pixel; consecutive
// invocations read consecutive pixels of each channel. The sum of squares is
// float32; when it overflows (|x| beyond ~1e19) or falls below 1e-25 (where
// flushed squares could matter) it is summed again with x scaled by 2^-80 or
// 2^64 (exact), n = sqrt(sum) / scale.
// Host module: kernels/nn/rms_norm.{h,cpp}; CPU reference: nn::cpu::rms_norm.
// Tests: tests/nn/test_rms_norm.cpp.
#include "shared/nn_gsm_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_RMS_GROUP) in;
layout(push_constant) uniform Push { RmsNormParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) readonly buffer Gamma { float gamma[]; };
layout(std430, binding = 2) writeonly buffer Out { float y_out[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.batch * p.pixels) return;
  const uint b = i / p.pixels, s = i % p.pixels;
  const uint xb = p.x_offset + b * p.batch_stride + s, yb = p.y_offset + b * p.batch_stride + s;
  float ss = 0.0;
  for (uint c = 0u; c < p.channels; ++c) {
    const float v = x_in[xb + c * p.plane];
    ss = fma(v, v, ss);
  }
  float norm = sqrt(ss);
  if (isinf(ss) || ss < 1e-25) {
    const float k = isinf(ss) ? exp2(-80.0) : exp2(64.0);
    float sk = 0.0;
    for (uint c = 0u; c < p.channels; ++c) {
      const float v = x_in[xb + c * p.plane] * k;
      sk = fma(v, v, sk);
    }
    norm = sqrt(sk) / k;
  }
  const float inv = p.scale / max(norm, p.eps);
  for (uint c = 0u; c < p.channels; ++c) {
    float v = x_in[xb + c * p.plane] * inv * gamma[c];
    if ((p.flags & NN_RMS_FLAG_SILU) != 0u) v = v / (1.0 + exp(-v));
    y_out[yb + c * p.plane] = v;
  }
}
