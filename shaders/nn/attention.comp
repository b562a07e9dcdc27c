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
// Host module: kernels/nn/attention.{h,cpp}. Tests: tests/nn/test_attention_gpu.cpp.
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
  float q[NN_ATTN_MAX_HEAD_DIM], acc[NN_ATTN_MAX_HEAD_DIM];
  for (uint d = 0u; d < D; ++d) {
    q[d] = q_in[p.q_offset + head_base + d * N + i] * p.scale;
    acc[d] = 0.0;
  }
  float m = -3.402823466e38, l = 0.0;
  for (uint j = 0u; j < N; ++j) {
    float s = 0.0;
    for (uint d = 0u; d < D; ++d) s = fma(q[d], k_in[p.k_offset + head_base + d * N + j], s);
    const float m_new = max(m, s);
    const float corr = exp(m - m_new), e = exp(s - m_new);
    l = l * corr + e;
    for (uint d = 0u; d < D; ++d) acc[d] = fma(e, v_in[p.v_offset + head_base + d * N + j], acc[d] * corr);
    m = m_new;
  }
  const uint out_base = b * p.out_batch_stride + h * D * N + i;
  for (uint d = 0u; d < D; ++d) out_data[out_base + d * N] = acc[d] / l;
}
