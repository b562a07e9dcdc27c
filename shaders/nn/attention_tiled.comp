#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_quad : require
// attention_tiled: out = softmax(q k^T * scale) v for every (batch, head), the
// same attention as nn/attention.comp (its header gives the layouts), for
// GPUs: one fused kernel with an online softmax and no N x N matrix in memory.
// A workgroup takes 64 queries of one (batch, head); each query is a quad of
// four threads, thread `lane` holding head dimensions lane, lane + 4, ... of
// the query and of its accumulator (32 registers each at head_dim 128), a
// score the quad's partial dot products summed by two quad swaps. Keys and
// values stream through shared memory 32 tokens at a time, loaded by the whole
// workgroup with coalesced reads (32 consecutive tokens of one dimension) and
// stored swizzled (dimension d of token j at j * 128 + (d ^ j)), so both the
// loads' stores and the quads' reads hit distinct banks. Per block: 32 scores,
// one running-max update, exp of differences only (huge logits stay finite).
// Host module: kernels/nn/attention.{h,cpp} (AttentionPath::kTiled); CPU
// reference: nn::cpu::attention. Tests: tests/nn/test_attention.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_ATTN_TILED_GROUP) in;
layout(push_constant) uniform Push { AttentionParams p; };
layout(std430, binding = 0) readonly buffer Q { float q_in[]; };
layout(std430, binding = 1) readonly buffer K { float k_in[]; };
layout(std430, binding = 2) readonly buffer V { float v_in[]; };
layout(std430, binding = 3) writeonly buffer Out { float out_data[]; };

const uint KB = NN_ATTN_TILED_KEYS, MAXD = NN_ATTN_MAX_HEAD_DIM, U = NN_ATTN_MAX_HEAD_DIM / 4u;
const uint QUERIES = NN_ATTN_TILED_GROUP / 4u;
shared float k_sh[KB * MAXD];
shared float v_sh[KB * MAXD];

float quad_sum(float x) {
  x += subgroupQuadSwapHorizontal(x);
  return x + subgroupQuadSwapVertical(x);
}

void main() {
  const uint N = p.tokens, D = p.head_dim;
  const uint q_blocks = (N + QUERIES - 1u) / QUERIES;
  const uint g = icube_group_linear();
  const uint bh = g / q_blocks;
  if (bh >= p.batch * p.heads) return;  // uniform across the workgroup
  const uint h = bh % p.heads, b = bh / p.heads;
  const uint tid = gl_LocalInvocationID.x, lane = tid % 4u;
  const uint i = (g % q_blocks) * QUERIES + tid / 4u;
  const uint ic = min(i, N - 1u);  // queries past the end compute a copy and write nothing
  const uint head_base = b * p.in_batch_stride + h * D * N;
  const uint kb = p.k_offset + head_base, vb = p.v_offset + head_base;

  float q[U], acc[U];
  for (uint u = 0u; u < U; ++u) {
    const uint d = 4u * u + lane;
    q[u] = d < D ? q_in[p.q_offset + head_base + d * N + ic] * p.scale : 0.0;
    acc[u] = 0.0;
  }
  float m = -3.402823466e38, l = 0.0;
  for (uint j0 = 0u; j0 < N; j0 += KB) {
    barrier();  // the previous block's reads are done
    // KB tokens x D dimensions of k and v: element e = (dimension e / KB, token e % KB).
    for (uint r = 0u; r < KB * MAXD / NN_ATTN_TILED_GROUP; ++r) {
      const uint e = r * NN_ATTN_TILED_GROUP + tid, j = e % KB, d = e / KB;
      if (d < D) {
        const uint src = d * N + min(j0 + j, N - 1u);
        k_sh[j * MAXD + (d ^ j)] = k_in[kb + src];
        v_sh[j * MAXD + (d ^ j)] = v_in[vb + src];
      }
    }
    barrier();
    float s[KB];
    float m_new = m;
    for (uint j = 0u; j < KB; ++j) {
      float part = 0.0;
      for (uint u = 0u; u < U; ++u)
        if (4u * u < D) part = fma(q[u], k_sh[j * MAXD + ((4u * u + lane) ^ j)], part);
      const float score = quad_sum(part);
      s[j] = j0 + j < N ? score : -3.402823466e38;
      m_new = max(m_new, s[j]);
    }
    const float corr = exp(m - m_new);
    l *= corr;
    for (uint u = 0u; u < U; ++u) acc[u] *= corr;
    for (uint j = 0u; j < KB; ++j) {
      const float e = exp(s[j] - m_new);
      l += e;
      for (uint u = 0u; u < U; ++u)
        if (4u * u < D) acc[u] = fma(e, v_sh[j * MAXD + ((4u * u + lane) ^ j)], acc[u]);
    }
    m = m_new;
  }
  if (i >= N) return;
  const uint out_base = b * p.out_batch_stride + h * D * N + i;
  for (uint u = 0u; u < U; ++u) {
    const uint d = 4u * u + lane;
    if (d < D) out_data[out_base + d * N] = acc[u] / l;
  }
}
