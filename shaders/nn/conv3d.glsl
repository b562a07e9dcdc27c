// conv3d's body, shared by nn/conv3d.comp (fp32 weights) and
// nn/conv3d_f16w.comp (NN_CONV_F16_WEIGHTS: fp16 weights); see conv3d.comp.
#include "conv3d_bindings.glsl"

layout(local_size_x = NN_CONV_GROUP) in;

vec4 acc_lo[NN_CONV_ZRUN], acc_hi[NN_CONV_ZRUN];

// All K z-taps of one input row (fixed ci, dx, dy): K is a literal at both
// call sites, so the loops unroll and `row` stays in registers.
void row_taps(const int K, uint x_row, bool row_valid, int z0, int Z, uint w_row) {
  const int H = K / 2;
  float row[NN_CONV_ZRUN + 2];
  for (int j = 0; j < NN_CONV_ZRUN + K - 1; ++j) {
    const int z = z0 + j - H;
    row[j] = row_valid && z >= 0 && z < Z ? texelFetch(x_tex, int(x_row + uint(z))).x : 0.0;
  }
  for (int kz = 0; kz < K; ++kz) {
    vec4 w_lo, w_hi;
    conv_weights8(w_row + uint(kz) * conv_weight_row_len(), w_lo, w_hi);
    for (int v = 0; v < NN_CONV_ZRUN; ++v) {
      acc_lo[v] = fma(w_lo, vec4(row[v + kz]), acc_lo[v]);
      acc_hi[v] = fma(w_hi, vec4(row[v + kz]), acc_hi[v]);
    }
  }
}

void main() {
  const ConvBlock blk = conv_block();
  const uint tile = blk.tile, cob = blk.cob, b = blk.batch;
  if (b >= p.batch) return;
  const uint S = p.size_x * p.size_y * p.size_z;
  const int X = int(p.size_x), Y = int(p.size_y), Z = int(p.size_z);
  const uint runs = (p.size_z + NN_CONV_ZRUN - 1u) / NN_CONV_ZRUN;
  const uint t_raw = tile * NN_CONV_GROUP + gl_LocalInvocationID.x;
  const bool in_grid = t_raw < p.size_x * p.size_y * runs;
  const uint t = in_grid ? t_raw : 0u;
  const int z0 = int(t % runs) * NN_CONV_ZRUN;
  const int yy = int((t / runs) % p.size_y);
  const int xx = int(t / (runs * p.size_y));
  const int K = NN_K, H = K / 2;
  const uint taps = uint(K * K * K);

  for (int v = 0; v < NN_CONV_ZRUN; ++v) {
    acc_lo[v] = vec4(0.0);
    acc_hi[v] = vec4(0.0);
  }
  const uint co_vec = conv_weight_column(cob);  // NN_CONV_CO_TILE = 8 channels per block
  const uint row_len = conv_weight_row_len();
  for (uint cl = 0u; cl < p.ci_count; ++cl) {
    const uint ci = p.ci_begin + cl;
    const uint x_base = p.x_offset + b * p.x_batch_stride + cl * S;
    for (int dx = 0; dx < K; ++dx) {
      const int qx = xx + dx - H;
      for (int dy = 0; dy < K; ++dy) {
        const int qy = yy + dy - H;
        const bool row_valid = qx >= 0 && qx < X && qy >= 0 && qy < Y;
        const uint x_row = x_base + uint(clamp(qx, 0, X - 1) * Y + clamp(qy, 0, Y - 1)) * uint(Z);
        const uint w_row = ((ci - p.w_ci_base) * taps + uint((dx * K + dy) * K)) * row_len + co_vec;
        row_taps(NN_K, x_row, row_valid, z0, Z, w_row);
      }
    }
  }
  if (!in_grid) return;
  const uint v0 = uint((xx * Y + yy) * Z + z0);
  for (int v = 0; v < NN_CONV_ZRUN; ++v) {
    if (z0 + v >= Z) break;
    for (uint c = 0u; c < NN_CONV_CO_TILE; ++c) {
      const uint cl = cob * NN_CONV_CO_TILE + c;  // channel within the window
      if (cl >= p.co_count) break;
      const float a = c < 4u ? acc_lo[v][c] : acc_hi[v][c - 4u];
      const uint yi = p.y_offset + b * p.y_batch_stride + cl * S + v0 + uint(v);
      if (p.accumulate != 0u) y_out[yi] += a;
      else y_out[yi] = a + (p.has_bias != 0u ? bias[p.co_begin + cl] : 0.0);
    }
  }
}
