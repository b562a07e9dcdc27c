// sparse_conv_coopmat's body, shared by nn/sparse_conv_coopmat*.comp
// (NN_COOPMAT_NV: GL_NV_cooperative_matrix; without it the fragments are
// emulated per lane so lavapipe tests the tiling; NN_CONV_F16_WEIGHTS: fp16
// weight storage): the submanifold 3^3 convolution of nn/sparse_conv.glsl as a
// gathered implicit GEMM over the kernel map (operands as
// nn/sparse_conv_tiled.glsl) on the tensor-core core of nn/gemm_coopmat.glsl
// (64 x 64 blocks of 2 x 2 fragments of 16 x 16 x 16 per subgroup, fp16
// operands, fp32 sums); the block is staged in shared memory so each thread
// writes consecutive rows of one channel, SiLU on the last input window.
#include "sparse_conv_bindings.glsl"

layout(local_size_x = NN_CONV_COOP_GROUP) in;

#include "gemm_coopmat.glsl"

void main() {
  const SparseBlock blk = sparse_block();
  const uint tile = blk.tile, cob = blk.cob;
  if (cob >= p.co_blocks) return;  // uniform across the workgroup
  g_k_count = p.ci_count * NN_SPARSE_TAPS;
  gemm_coopmat(tile * GEMM_COOP_BM, cob, g_k_count);

  const uint m = tile * GEMM_COOP_BM + gemm_coop_out_m();
  if (m >= p.row_count) return;
  for (uint n = gemm_coop_out_n0(); n < GEMM_COOP_BN; n += GEMM_COOP_OUT_N_STEP) {
    const uint ca = cob * GEMM_COOP_BN + n;  // computed channel from p.co_begin
    if (ca >= sparse_co_end()) break;
    sparse_store(ca, m, gemm_coop_c(gemm_coop_out_m(), n));
  }
}
