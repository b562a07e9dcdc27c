#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv_tiled: the submanifold 3^3 convolution of nn/sparse_conv.comp
// (its header gives the layouts),
//   y[co, r] = bias[co] + sum_{tap, ci} w[co, ci, tap] * x[ci, kmap[r, tap]],
// for GPUs as a gathered implicit GEMM (the fVDB / spconv approach): M = the
// row window's rows, N = output channels, K = input channels x 27 taps, on the
// shared-memory core of nn/gemm_tiled.glsl (64 x 64 blocks, double-buffered K
// steps of 16, 4 x 4 micro-tiles). A[r][k] is gathered through the kernel map
// (a missing neighbour, -1, reads 0) from the input texel buffer; the output
// is written once per window (deterministic, no atomics), SiLU on the last
// input window's store as the VAE's conv -> SiLU.
// Host module: kernels/nn/sparse_conv.{h,cpp} (SparseConvPath::kSharedTile);
// CPU reference: nn::cpu::conv3d on SparseTensor. Tests: tests/nn/test_sparse_conv.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_CONV_TILED_GROUP) in;
layout(push_constant) uniform Push { SparseConvParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT
layout(std430, binding = 1) readonly buffer Map { int kmap[]; };
layout(std430, binding = 2) readonly buffer Weights { vec4 w_packed[]; };
layout(std430, binding = 3) readonly buffer Bias { float bias[]; };
layout(std430, binding = 4) buffer Out { float y_out[]; };

// The GEMM core's operands: rows are the window's rows (kernel-map rows from the window's start).
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
#include "gemm_tiled.glsl"

void main() {
  const uint g = icube_group_linear();
  const uint tile = g % p.row_tiles;
  const uint cob = g / p.row_tiles;
  if (cob >= p.co_blocks) return;  // uniform across the workgroup
  g_k_count = p.ci_count * NN_SPARSE_TAPS;
  vec4 acc[4];
  gemm_tiled(tile * GEMM_BM, cob, g_k_count, acc);

  const uint m0 = tile * GEMM_BM + 4u * gemm_tm();
  for (uint j = 0u; j < 4u; ++j) {
    const uint cl = cob * GEMM_BN + 4u * gemm_tn() + j;  // channel within the window
    if (cl >= p.co_count) break;
    const float bias_c = p.has_bias != 0u && p.accumulate == 0u ? bias[p.co_begin + cl] : 0.0;
    for (uint i = 0u; i < 4u; ++i) {
      if (m0 + i >= p.row_count) break;
      const uint yi = p.y_offset + cl * p.rows + p.row_begin + m0 + i;
      float value = p.accumulate != 0u ? y_out[yi] + acc[j][i] : acc[j][i] + bias_c;
      if (p.silu != 0u) value = value / (1.0 + exp(-value));
      y_out[yi] = value;
    }
  }
}
