// conv3d_coopmat's body, shared by nn/conv3d_coopmat.comp (NN_COOPMAT_NV:
// GL_NV_cooperative_matrix) and nn/conv3d_coopmat_emulated.comp (the same
// tiling with each fragment operation written out per lane, so the kernel's
// indexing runs and is tested on devices without cooperative matrices): the
// convolution's operands (conv3d_operands.glsl) on the core of
// nn/gemm_coopmat.glsl; see conv3d_coopmat.comp.
#include "conv3d_bindings.glsl"

layout(local_size_x = NN_CONV_COOP_GROUP) in;

#include "conv3d_operands.glsl"

uint g_k_count, g_x_base;
#define GemmRow ConvVoxel
GemmRow gemm_row(uint m) { return conv_voxel(m); }
float gemm_a(GemmRow r, uint k) { return conv_a(r, k, g_k_count, g_x_base); }
uint gemm_weight_row(uint k) { return conv_weight_row(k); }
#include "gemm_coopmat.glsl"

void main() {
  const ConvBlock blk = conv_block();
  const uint tile = blk.tile, cob = blk.cob, b = blk.batch;
  if (b >= p.batch) return;  // uniform across the workgroup
  const uint S = p.size_x * p.size_y * p.size_z;
  g_k_count = p.ci_count * NN_TAPS;
  g_x_base = p.x_offset + b * p.x_batch_stride;
  gemm_coopmat(tile * GEMM_COOP_BM, cob, g_k_count);

  const uint ml = gemm_coop_out_m(), m = tile * GEMM_COOP_BM + ml;
  if (m >= S) return;
  for (uint n = gemm_coop_out_n0(); n < GEMM_COOP_BN; n += GEMM_COOP_OUT_N_STEP) {
    const uint cl = cob * GEMM_COOP_BN + n;  // channel within the window
    if (cl >= p.co_count) break;
    const uint yi = p.y_offset + b * p.y_batch_stride + cl * S + m;
    const float v = gemm_coop_c(ml, n);
    if (p.accumulate != 0u) y_out[yi] += v;
    else y_out[yi] = v + (p.has_bias != 0u ? bias[p.co_begin + cl] : 0.0);
  }
}
