#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv: submanifold 3^3 convolution of a sparse voxel tensor,
//   y[co, r] = bias[co] + sum_{tap, ci} w[co, ci, tap] * x[ci, kmap[r, tap]]
// (missing neighbours, kmap = -1, read zero), features channel-major [C][N],
// taps in grid order (a along i; fVDB 0.2.0 checkpoints are converted on load,
// engine/nn/vae_weights.h). An output-stationary gather: deterministic, no
// atomics, output written once. Each invocation holds NN_SPARSE_ROWS
// consecutive rows x NN_CONV_CO_TILE output channels in vec4 accumulators; per
// tap it reads the rows' neighbours once, then per input channel two vec4s of
// weights (uniform across the workgroup) and one value per row. Missing
// neighbours load row 0 and are zeroed by a select, so no lane branches. The
// features are fetched as an R32_SFLOAT texel buffer (one hardware gather on
// lavapipe, where a storage load at a per-lane address is a loop over lanes).
// Windows of input / output channels as nn/conv3d.comp (SparseConvParams);
// p.silu applies SiLU on the final store (the VAE's ConvBlock "gcs": conv then SiLU).
// Host module: kernels/nn/sparse_conv.{h,cpp}. CPU reference: nn::cpu::conv3d
// on SparseTensor (kernels/nn/sparse_cpu.h). Tests: tests/nn/test_sparse_conv.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseConvParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT: a gather on lavapipe
layout(std430, binding = 1) readonly buffer Map { int kmap[]; };
layout(std430, binding = 2) readonly buffer Weights { vec4 w_packed[]; };
layout(std430, binding = 3) readonly buffer Bias { float bias[]; };
layout(std430, binding = 4) buffer Out { float y_out[]; };

void main() {
  const uint g = icube_group_linear();
  const uint tile = g % p.row_tiles;
  const uint cob = g / p.row_tiles;
  if (cob >= p.co_blocks) return;
  const uint r0 = (tile * NN_SPARSE_GROUP + gl_LocalInvocationID.x) * NN_SPARSE_ROWS;  // within the row window
  const uint last = p.row_count - 1u;
  const uint co_vec = p.co_begin / 4u + cob * (NN_CONV_CO_TILE / 4);

  vec4 acc_lo[NN_SPARSE_ROWS], acc_hi[NN_SPARSE_ROWS];
  for (int v = 0; v < NN_SPARSE_ROWS; ++v) {
    acc_lo[v] = vec4(0.0);
    acc_hi[v] = vec4(0.0);
  }
  for (uint tap = 0u; tap < NN_SPARSE_TAPS; ++tap) {
    int nbr[NN_SPARSE_ROWS];
    for (int v = 0; v < NN_SPARSE_ROWS; ++v) nbr[v] = kmap[min(r0 + uint(v), last) * NN_SPARSE_TAPS + tap];
    for (uint cl = 0u; cl < p.ci_count; ++cl) {
      const uint wi = ((p.ci_begin - p.w_ci_base + cl) * NN_SPARSE_TAPS + tap) * p.co_vec4s + co_vec;
      const vec4 w_lo = w_packed[wi];
      const vec4 w_hi = w_packed[wi + 1u];
      const uint base = p.x_offset + cl * p.rows;
      for (int v = 0; v < NN_SPARSE_ROWS; ++v) {
        const float xr = texelFetch(x_tex, int(base + uint(max(nbr[v], 0)))).x;
        const float xv = nbr[v] >= 0 ? xr : 0.0;
        acc_lo[v] = fma(w_lo, vec4(xv), acc_lo[v]);
        acc_hi[v] = fma(w_hi, vec4(xv), acc_hi[v]);
      }
    }
  }
  for (int v = 0; v < NN_SPARSE_ROWS; ++v) {
    if (r0 + uint(v) > last) break;
    const uint r = p.row_begin + r0 + uint(v);
    for (uint c = 0u; c < NN_CONV_CO_TILE; ++c) {
      const uint cl = cob * NN_CONV_CO_TILE + c;  // channel within the window
      if (cl >= p.co_count) break;
      const float a = c < 4u ? acc_lo[v][c] : acc_hi[v][c - 4u];
      const uint yi = p.y_offset + cl * p.rows + r;
      float value = p.accumulate != 0u ? y_out[yi] + a : a + (p.has_bias != 0u ? bias[p.co_begin + cl] : 0.0);
      if (p.silu != 0u) value = value / (1.0 + exp(-value));
      y_out[yi] = value;
    }
  }
}
