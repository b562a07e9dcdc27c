// sparse_conv_tiled's body, shared by nn/sparse_conv_tiled.comp and
// nn/sparse_conv_tiled_f16w.comp (NN_CONV_F16_WEIGHTS): the submanifold 3^3
// convolution of nn/sparse_conv.glsl (its header gives the layouts),
//   y[co, r] = bias[co] + sum_{tap, ci} w[co, ci, tap] * x[ci, kmap[r, tap]],
// for GPUs as a gathered implicit GEMM (the fVDB / spconv approach): M = the
// row window's rows, N = output channels, K = input channels x 27 taps, on the
// shared-memory core of nn/gemm_tiled.glsl (64 x 64 blocks, double-buffered K
// steps of 16, 4 x 4 micro-tiles). A[r][k] is gathered through the kernel map
// (a missing neighbour, -1, reads 0) from the input texel buffer; the output
// is written once per window (deterministic, no atomics), SiLU on the last
// input window's store as the VAE's conv -> SiLU.
#include "sparse_conv_bindings.glsl"

layout(local_size_x = NN_CONV_TILED_GROUP) in;

#include "gemm_tiled.glsl"

void main() {
  const SparseBlock blk = sparse_block();
  const uint tile = blk.tile, cob = blk.cob;
  if (cob >= p.co_blocks) return;  // uniform across the workgroup
  g_k_count = p.ci_count * NN_SPARSE_TAPS;
  vec4 acc[4];
  gemm_tiled(tile * GEMM_BM, cob, g_k_count, acc);

  const uint m0 = tile * GEMM_BM + 4u * gemm_tm();
  for (uint j = 0u; j < 4u; ++j) {
    const uint ca = cob * GEMM_BN + 4u * gemm_tn() + j;  // computed channel from p.co_begin
    if (ca >= sparse_co_end()) break;
    for (uint i = 0u; i < 4u; ++i) {
      if (m0 + i >= p.row_count) break;
      sparse_store(ca, m0 + i, acc[j][i]);
    }
  }
}
