// conv3d_tiled's body, shared by nn/conv3d_tiled.comp (fp32 weights) and
// nn/conv3d_tiled_f16w.comp (NN_CONV_F16_WEIGHTS); see conv3d_tiled.comp.
#include "conv3d_bindings.glsl"

layout(local_size_x = NN_CONV_TILED_GROUP) in;

#include "conv3d_operands.glsl"

// The GEMM core's operands: rows are voxels of batch element g_batch.
uint g_k_count, g_x_base;
#define GemmRow ConvVoxel
GemmRow gemm_row(uint m) { return conv_voxel(m); }
float gemm_a(GemmRow r, uint k) { return conv_a(r, k, g_k_count, g_x_base); }
uint gemm_weight_row(uint k) { return conv_weight_row(k); }
#include "gemm_tiled.glsl"

void main() {
  const ConvBlock blk = conv_block();
  const uint tile = blk.tile, cob = blk.cob, b = blk.batch;
  if (b >= p.batch) return;  // uniform across the workgroup
  const uint S = p.size_x * p.size_y * p.size_z;
  g_k_count = p.ci_count * NN_TAPS;
  g_x_base = p.x_offset + b * p.x_batch_stride;
  vec4 acc[4];
  gemm_tiled(tile * GEMM_BM, cob, g_k_count, acc);

  const uint m0 = tile * GEMM_BM + 4u * gemm_tm();
  for (uint j = 0u; j < 4u; ++j) {
    const uint cl = cob * GEMM_BN + 4u * gemm_tn() + j;  // channel within the window
    if (cl >= p.co_count) break;
    const uint y_base = p.y_offset + b * p.y_batch_stride + cl * S;
    const float bias_c = p.has_bias != 0u && p.accumulate == 0u ? bias[p.co_begin + cl] : 0.0;
    for (uint i = 0u; i < 4u; ++i) {
      if (m0 + i >= S) break;
      if (p.accumulate != 0u) y_out[y_base + m0 + i] += acc[j][i];
      else y_out[y_base + m0 + i] = acc[j][i] + bias_c;
    }
  }
}
