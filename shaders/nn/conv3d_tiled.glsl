// conv3d_tiled's body, shared by nn/conv3d_tiled.comp (fp32 weights) and
// nn/conv3d_tiled_f16w.comp (NN_CONV_F16_WEIGHTS); see conv3d_tiled.comp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_CONV_TILED_GROUP) in;
layout(constant_id = 0) const int NN_K = 3;
layout(push_constant) uniform Push { Conv3dParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT
#ifdef NN_CONV_F16_WEIGHTS
layout(std430, binding = 1) readonly buffer Weights { uvec4 w_packed[]; };  // 8 halves
#else
layout(std430, binding = 1) readonly buffer Weights { vec4 w_packed[]; };
#endif
layout(std430, binding = 2) readonly buffer Bias { float bias[]; };
layout(std430, binding = 3) buffer Out { float y_out[]; };

#include "conv3d_operands.glsl"

const uint BM = NN_CONV_TILED_BM, BN = NN_CONV_TILED_BN, BK = NN_CONV_TILED_BK;
const uint A_ROWS_PER_PASS = NN_CONV_TILED_GROUP / BM;      // 4: each thread loads BK / 4 A values
const uint A_LOADS = BK / A_ROWS_PER_PASS;
shared vec4 a_tile[2][BK][BM / 4];  // [k][voxels / 4]
shared vec4 b_tile[2][BK][BN / 4];  // [k][channels / 4]

void main() {
  const uint g = icube_group_linear();
  const uint tile = g % p.voxel_tiles;
  const uint rest = g / p.voxel_tiles;
  const uint cob = rest % p.co_blocks;
  const uint b = rest / p.co_blocks;
  if (b >= p.batch) return;  // uniform across the workgroup
  const uint tid = gl_LocalInvocationID.x;
  const uint S = p.size_x * p.size_y * p.size_z;
  const uint k_count = p.ci_count * NN_TAPS;
  const uint x_base = p.x_offset + b * p.x_batch_stride;

  // Loader roles: A column a_m (one voxel, rows a_k0 + 4i), B one vector of row b_k.
  const uint a_m = tid % BM, a_k0 = tid / BM;
  const ConvVoxel av = conv_voxel(tile * BM + a_m);
#ifdef NN_CONV_F16_WEIGHTS
  const uint row_len = p.co_vec4s / 2u;  // uvec4s of 8 halves
  const bool b_loader = tid < BK * (BN / 8u);
  const uint b_k = tid / (BN / 8u), b_c = (p.co_begin + cob * BN) / 8u + tid % (BN / 8u);
  uvec4 b_reg;
#else
  const uint row_len = p.co_vec4s;
  const bool b_loader = true;
  const uint b_k = tid / (BN / 4u), b_c = (p.co_begin + cob * BN) / 4u + tid % (BN / 4u);
  vec4 b_reg;
#endif
  float a_reg[A_LOADS];

  // Compute role: voxels 4 tm .. 4 tm + 3, channels 4 tn .. 4 tn + 3.
  const uint tm = tid % (BM / 4u), tn = tid / (BM / 4u);
  vec4 acc[4];  // acc[j] = 4 voxels of channel 4 tn + j
  for (uint j = 0u; j < 4u; ++j) acc[j] = vec4(0.0);

  const uint steps = (k_count + BK - 1u) / BK;
  for (uint t = 0u; t <= steps; ++t) {
    // Load step t into registers (global loads in flight during step t - 1's FMAs) ...
    if (t < steps) {
      for (uint i = 0u; i < A_LOADS; ++i) a_reg[i] = conv_a(av, t * BK + a_k0 + A_ROWS_PER_PASS * i, k_count, x_base);
      const uint k = t * BK + b_k;
      const bool live = b_loader && k < k_count && b_c < row_len;
#ifdef NN_CONV_F16_WEIGHTS
      b_reg = live ? w_packed[conv_weight_row(k) * row_len + b_c] : uvec4(0u);
#else
      b_reg = live ? w_packed[conv_weight_row(k) * row_len + b_c] : vec4(0.0);
#endif
    }
    // ... multiply step t - 1 from shared memory ...
    if (t > 0u) {
      const uint buf = (t - 1u) & 1u;
      for (uint kk = 0u; kk < BK; ++kk) {
        const vec4 a = a_tile[buf][kk][tm];
        const vec4 w = b_tile[buf][kk][tn];
        acc[0] = fma(a, vec4(w.x), acc[0]);
        acc[1] = fma(a, vec4(w.y), acc[1]);
        acc[2] = fma(a, vec4(w.z), acc[2]);
        acc[3] = fma(a, vec4(w.w), acc[3]);
      }
    }
    // ... and store step t into the other buffer: one barrier per step (the
    // barrier after step t - 2's FMAs freed it).
    if (t < steps) {
      const uint buf = t & 1u;
      for (uint i = 0u; i < A_LOADS; ++i) a_tile[buf][a_k0 + A_ROWS_PER_PASS * i][a_m / 4u][a_m % 4u] = a_reg[i];
#ifdef NN_CONV_F16_WEIGHTS
      if (b_loader) {
        b_tile[buf][b_k][2u * (tid % (BN / 8u))] = vec4(unpackHalf2x16(b_reg.x), unpackHalf2x16(b_reg.y));
        b_tile[buf][b_k][2u * (tid % (BN / 8u)) + 1u] = vec4(unpackHalf2x16(b_reg.z), unpackHalf2x16(b_reg.w));
      }
#else
      b_tile[buf][b_k][tid % (BN / 4u)] = b_reg;
#endif
    }
    barrier();
  }

  const uint m0 = tile * BM + 4u * tm;
  for (uint j = 0u; j < 4u; ++j) {
    const uint cl = cob * BN + 4u * tn + j;  // channel within the window
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
