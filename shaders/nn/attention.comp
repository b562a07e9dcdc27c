#version 460
#extension GL_GOOGLE_include_directive : require
// attention: out = softmax(q k^T * scale) v for every (batch, head), the
// UNet's AttentionBlock (q, k, v = thirds of one qkv conv output) and the
// transformer's self-attention (three linears), on channels-first tensors
// (AttentionParams in shared/nn_params.h). One thread per query: the query and
// its accumulator live in registers (head_dim <= NN_ATTN_MAX_HEAD_DIM), keys
// and values are read once per query in order (uniform across a workgroup of
// queries, consecutive queries adjacent in memory), softmax online in fp32
// (running max and sum; exp of differences only, so huge logits stay finite).
// Keys go 4 per iteration and head dimensions 8 per iteration (constant inner
// loops, unrolled): lavapipe's gallivm stops an invocation after 65,535 loop
// iterations in all (LP_MAX_TGSI_LOOP_ITERATIONS), and this kernel makes
// about ceil(N / 4) * (2 * ceil(D / 8) + 1) of them (25,600 at 4,096 tokens,
// D = 96); the host refuses shapes beyond NN_ATTN_LOOP_BUDGET on CPU devices.
// Host module: kernels/nn/attention.{h,cpp}. Tests: tests/nn/test_attention.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_ATTN_GROUP) in;
layout(push_constant) uniform Push { AttentionParams p; };
layout(std430, binding = 0) readonly buffer Q { float q_in[]; };
layout(std430, binding = 1) readonly buffer K { float k_in[]; };
layout(std430, binding = 2) readonly buffer V { float v_in[]; };
layout(std430, binding = 3) writeonly buffer Out { float out_data[]; };

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  const uint N = p.tokens, D = p.head_dim;
  if (t >= p.batch * p.heads * N) return;
  const uint i = t % N, h = (t / N) % p.heads, b = t / (N * p.heads);
  const uint head_base = b * p.in_batch_stride + h * D * N;
  const uint kb = p.k_offset + head_base, vb = p.v_offset + head_base;
  float q[NN_ATTN_MAX_HEAD_DIM], acc[NN_ATTN_MAX_HEAD_DIM];
  for (uint d0 = 0u; d0 < D; d0 += 8u)
    for (uint u = 0u; u < 8u; ++u) {
      const uint d = d0 + u;
      q[d] = d < D ? q_in[p.q_offset + head_base + d * N + i] * p.scale : 0.0;
      acc[d] = 0.0;
    }
  float m = -3.402823466e38, l = 0.0;
  for (uint j0 = 0u; j0 < N; j0 += 4u) {
    // Keys past the end repeat the last one (in-range loads) and get weight 0.
    const uvec4 j = min(uvec4(j0) + uvec4(0u, 1u, 2u, 3u), uvec4(N - 1u));
    const bvec4 live = lessThan(uvec4(j0) + uvec4(0u, 1u, 2u, 3u), uvec4(N));
    vec4 s = vec4(0.0);
    for (uint d0 = 0u; d0 < D; d0 += 8u)
      for (uint u = 0u; u < 8u; ++u) {
        const uint d = min(d0 + u, D - 1u), row = kb + d * N;
        const vec4 kv = vec4(k_in[row + j.x], k_in[row + j.y], k_in[row + j.z], k_in[row + j.w]);
        s = d0 + u < D ? fma(vec4(q[d0 + u]), kv, s) : s;
      }
    const float m_new = max(m, max(max(s.x, s.y), max(s.z, s.w)));
    const float corr = exp(m - m_new);
    const vec4 e = mix(vec4(0.0), exp(s - m_new), live);
    l = l * corr + (e.x + e.y) + (e.z + e.w);
    for (uint d0 = 0u; d0 < D; d0 += 8u)
      for (uint u = 0u; u < 8u; ++u) {
        const uint d = min(d0 + u, D - 1u), row = vb + d * N;
        const vec4 vv = vec4(v_in[row + j.x], v_in[row + j.y], v_in[row + j.z], v_in[row + j.w]);
        acc[d0 + u] = fma(acc[d0 + u], corr, dot(e, vv));
      }
    m = m_new;
  }
  const uint out_base = b * p.out_batch_stride + h * D * N + i;
  for (uint d0 = 0u; d0 < D; d0 += 8u)
    for (uint u = 0u; u < 8u; ++u)
      if (d0 + u < D) out_data[out_base + (d0 + u) * N] = acc[d0 + u] / l;
}
