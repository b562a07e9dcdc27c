// sparse_conv's body, shared by nn/sparse_conv.comp and nn/sparse_conv_f16w.comp
// (NN_CONV_F16_WEIGHTS: each tap's 8 output-channel weights as one uvec4 of
// halves). sparse_conv: submanifold 3^3 convolution of a sparse voxel tensor,
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
#include "sparse_conv_bindings.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;

void main() {
  const SparseBlock blk = sparse_block();
  const uint tile = blk.tile, cob = blk.cob;
  if (cob >= p.co_blocks) return;
  const uint r0 = (tile * NN_SPARSE_GROUP + gl_LocalInvocationID.x) * NN_SPARSE_ROWS;  // within the row window
  const uint last = p.row_count - 1u;
  const uint co_vec = conv_weight_column(cob);  // NN_CONV_CO_TILE = 8 channels per block
  const uint row_len = conv_weight_row_len();

  vec4 acc_lo[NN_SPARSE_ROWS], acc_hi[NN_SPARSE_ROWS];
  for (int v = 0; v < NN_SPARSE_ROWS; ++v) {
    acc_lo[v] = vec4(0.0);
    acc_hi[v] = vec4(0.0);
  }
  for (uint tap = 0u; tap < NN_SPARSE_TAPS; ++tap) {
    int nbr[NN_SPARSE_ROWS];
    for (int v = 0; v < NN_SPARSE_ROWS; ++v) nbr[v] = kmap[min(r0 + uint(v), last) * NN_SPARSE_TAPS + tap];
    for (uint cl = 0u; cl < p.ci_count; ++cl) {
      const uint wi = ((p.ci_begin - p.w_ci_base + cl) * NN_SPARSE_TAPS + tap) * row_len + co_vec;
      vec4 w_lo, w_hi;
      conv_weights8(wi, w_lo, w_hi);
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
    for (uint c = 0u; c < NN_CONV_CO_TILE; ++c) {
      const uint ca = cob * NN_CONV_CO_TILE + c;  // computed channel from p.co_begin
      if (ca >= sparse_co_end()) break;
      sparse_store(ca, r0 + uint(v), c < 4u ? acc_lo[v][c] : acc_hi[v][c - 4u]);
    }
  }
}
