// The bindings, push constants, workgroup decomposition, implicit-GEMM
// operands and output store every sparse_conv kernel shares (sparse_conv.glsl,
// sparse_conv_tiled.glsl, sparse_conv_coopmat.glsl: the host module
// kernels/nn/sparse_conv.cpp binds them alike for every path).
// NN_CONV_F16_WEIGHTS: fp16 packed weights (nn/conv_weights.glsl).
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(push_constant) uniform Push { SparseConvParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT: a gather on lavapipe
layout(std430, binding = 1) readonly buffer Map { int kmap[]; };
#define NN_CONV_WEIGHTS_BINDING 2
#include "conv_weights.glsl"
layout(std430, binding = 3) readonly buffer Bias { float bias[]; };
layout(std430, binding = 4) buffer Out { float y_out[]; };

// Workgroup g: row tile g % row_tiles, then output-channel block (cob >= p.co_blocks: past the end,
// uniform across the workgroup).
struct SparseBlock {
  uint tile, cob;
};
SparseBlock sparse_block() {
  const uint g = icube_group_linear();
  return SparseBlock(g % p.row_tiles, g / p.row_tiles);
}

// The gathered implicit GEMM's operands for the tiled paths (nn/gemm_tiled.glsl, nn/gemm_coopmat.glsl):
// rows are the row window's rows, A[r][k] = x[ci, kmap[r, tap]] with k = ci * 27 + tap in the dispatch's
// input-channel window (a missing neighbour, -1, reads 0), B[k] = the packed weight row.
uint g_k_count;
struct GemmRow {
  uint r;
  bool valid;
};
GemmRow gemm_row(uint m) { return GemmRow(min(m, p.row_count - 1u), m < p.row_count); }
float gemm_a(GemmRow row, uint k) {
  if (!row.valid || k >= g_k_count) return 0.0;
  const uint cl = k / NN_SPARSE_TAPS, tap = k - cl * NN_SPARSE_TAPS;
  const int nbr = kmap[row.r * NN_SPARSE_TAPS + tap];
  return nbr >= 0 ? texelFetch(x_tex, int(p.x_offset + cl * p.rows + uint(nbr))).x : 0.0;
}
uint gemm_weight_row(uint k) { return (p.ci_begin - p.w_ci_base) * NN_SPARSE_TAPS + k; }

// The computed channels from p.co_begin: the window's lead, then its channels.
uint sparse_co_end() { return p.co_lead + p.co_count; }

// Stores the sum `a` of computed channel ca (from p.co_begin) at window row m: + bias (first input
// window) or + y (later windows), SiLU on the last input window; the lead's channels are not stored.
void sparse_store(uint ca, uint m, float a) {
  if (ca < p.co_lead) return;
  const uint yi = p.y_offset + (ca - p.co_lead) * p.rows + p.row_begin + m;
  float value = p.accumulate != 0u ? y_out[yi] + a : a + (p.has_bias != 0u ? bias[p.co_begin + ca] : 0.0);
  if (p.silu != 0u) value = value / (1.0 + exp(-value));
  y_out[yi] = value;
}
