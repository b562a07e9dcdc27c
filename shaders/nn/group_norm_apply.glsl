// group_norm_apply: pass 3 of GroupNorm, one thread per element:
// y = ((x - shift) - (mean - shift)) * rstd * weight[c] + bias[c], then optionally the ResBlock's
// scale-shift modulation y * (1 + scale[b, c]) + shift[b, c] and SiLU
// y / (1 + exp(-y)) (NN_GN_FLAG_*), fused so the tensor is read and written once.
// Thread i is element span_begin + i of the window's channels (span_begin > 0
// when a group larger than one binding is applied in pieces).
// The output is fp32, or fp16 with NN_NORM_F16_OUTPUT (group_norm_apply_f16out.comp).
// Host module: kernels/nn/group_norm.{h,cpp}. Tests: tests/nn/test_group_norm.cpp.
#include "shared/nn_params.h"
#include "norm_output.glsl"
#include "common/dispatch.glsl"

layout(local_size_x = NN_GN_GROUP) in;
layout(push_constant) uniform Push { GroupNormParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) readonly buffer Stats { vec4 stats[]; };
layout(std430, binding = 2) readonly buffer Weight { float gn_weight[]; };
layout(std430, binding = 3) readonly buffer Bias { float gn_bias[]; };
layout(std430, binding = 4) readonly buffer Modulation { float modulation[]; };
layout(std430, binding = 5) writeonly buffer Out { norm_store_t y_out[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.span_end - p.span_begin) return;
  const uint bc = (p.span_begin + i) / p.spatial;
  const uint cl = bc % p.channels, bl = bc / p.channels;  // in the window
  const uint c = p.channel_offset + cl, b = p.batch_offset + bl;  // in the whole tensor
  const vec4 st = stats[bl * p.groups + cl / (p.channels / p.groups)];  // (shift, mean - shift, rstd)
  float y = ((x_in[p.x_offset + i] - st.x) - st.y) * st.z * gn_weight[c] + gn_bias[c];
  if ((p.flags & NN_GN_FLAG_MODULATE) != 0u)
    y = y * (1.0 + modulation[b * 2u * p.channels_total + c]) + modulation[b * 2u * p.channels_total + p.channels_total + c];
  if ((p.flags & NN_GN_FLAG_SILU) != 0u) y = y / (1.0 + exp(-y));
  y_out[p.y_offset + i] = norm_store_t(y);
}
