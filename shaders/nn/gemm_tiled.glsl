// The shared-memory implicit-GEMM core of the GPU convolutions (conv3d_tiled,
// sparse_conv_tiled): a 64 x 64 block of C[m][n] = sum_k A[m][k] B[k][n] per
// workgroup of 256 threads, K in double-buffered steps of 16 through shared
// memory (one barrier per step; the next step's global loads are issued
// before the current step's FMAs), each thread a 4 x 4 register micro-tile
// (4 consecutive rows m x 4 consecutive columns n) read as vec4s.
// B is the packed weight rows [k][output channels padded to 8] (vec4s, or
// uvec4s of 8 halves with NN_CONV_F16_WEIGHTS) at columns from p.co_begin.
// Expects before inclusion: `p` (co_begin, co_vec4s), the binding `w_packed`,
// a row type GemmRow with GemmRow gemm_row(uint m) (m past the rows: a row
// whose A values are 0), float gemm_a(GemmRow r, uint k) (0 for k past
// k_count) and uint gemm_weight_row(uint k).
const uint GEMM_BM = NN_CONV_TILED_BM, GEMM_BN = NN_CONV_TILED_BN, GEMM_BK = NN_CONV_TILED_BK;
const uint GEMM_A_ROWS_PER_PASS = NN_CONV_TILED_GROUP / GEMM_BM;  // 4: each thread loads BK / 4 A values
const uint GEMM_A_LOADS = GEMM_BK / GEMM_A_ROWS_PER_PASS;
shared vec4 gemm_a_tile[2][GEMM_BK][GEMM_BM / 4];  // [k][rows / 4]
shared vec4 gemm_b_tile[2][GEMM_BK][GEMM_BN / 4];  // [k][columns / 4]

// This thread's micro-tile: rows 4 tm .. 4 tm + 3 and columns 4 tn .. 4 tn + 3 of the block.
uint gemm_tm() { return gl_LocalInvocationID.x % (GEMM_BM / 4u); }
uint gemm_tn() { return gl_LocalInvocationID.x / (GEMM_BM / 4u); }

// The block of rows m_base.. and column block `cob` (64 channels from p.co_begin + 64 cob):
// acc[j] = the 4 rows of column 4 tn + j. Every thread of the workgroup must call it.
void gemm_tiled(uint m_base, uint cob, uint k_count, out vec4 acc[4]) {
  const uint tid = gl_LocalInvocationID.x;
  // Loader roles: A column a_m (one row, k = a_k0 + 4 i), B one vector of row b_k.
  const uint a_m = tid % GEMM_BM, a_k0 = tid / GEMM_BM;
  const GemmRow row = gemm_row(m_base + a_m);
#ifdef NN_CONV_F16_WEIGHTS
  const uint row_len = p.co_vec4s / 2u;  // uvec4s of 8 halves
  const bool b_loader = tid < GEMM_BK * (GEMM_BN / 8u);
  const uint b_k = tid / (GEMM_BN / 8u), b_v = tid % (GEMM_BN / 8u), b_c = (p.co_begin + cob * GEMM_BN) / 8u + b_v;
  uvec4 b_reg;
#else
  const uint row_len = p.co_vec4s;
  const bool b_loader = true;
  const uint b_k = tid / (GEMM_BN / 4u), b_v = tid % (GEMM_BN / 4u), b_c = (p.co_begin + cob * GEMM_BN) / 4u + b_v;
  vec4 b_reg;
#endif
  float a_reg[GEMM_A_LOADS];
  const uint tm = gemm_tm(), tn = gemm_tn();
  for (uint j = 0u; j < 4u; ++j) acc[j] = vec4(0.0);

  const uint steps = (k_count + GEMM_BK - 1u) / GEMM_BK;
  for (uint t = 0u; t <= steps; ++t) {
    // Load step t into registers ...
    if (t < steps) {
      for (uint i = 0u; i < GEMM_A_LOADS; ++i) a_reg[i] = gemm_a(row, t * GEMM_BK + a_k0 + GEMM_A_ROWS_PER_PASS * i);
      const uint k = t * GEMM_BK + b_k;
      const bool live = b_loader && k < k_count && b_c < row_len;
#ifdef NN_CONV_F16_WEIGHTS
      b_reg = live ? w_packed[gemm_weight_row(k) * row_len + b_c] : uvec4(0u);
#else
      b_reg = live ? w_packed[gemm_weight_row(k) * row_len + b_c] : vec4(0.0);
#endif
    }
    // ... multiply step t - 1 from shared memory ...
    if (t > 0u) {
      const uint buf = (t - 1u) & 1u;
      for (uint kk = 0u; kk < GEMM_BK; ++kk) {
        const vec4 a = gemm_a_tile[buf][kk][tm];
        const vec4 w = gemm_b_tile[buf][kk][tn];
        acc[0] = fma(a, vec4(w.x), acc[0]);
        acc[1] = fma(a, vec4(w.y), acc[1]);
        acc[2] = fma(a, vec4(w.z), acc[2]);
        acc[3] = fma(a, vec4(w.w), acc[3]);
      }
    }
    // ... and store step t into the other buffer (the barrier after step t - 2's FMAs freed it).
    if (t < steps) {
      const uint buf = t & 1u;
      for (uint i = 0u; i < GEMM_A_LOADS; ++i)
        gemm_a_tile[buf][a_k0 + GEMM_A_ROWS_PER_PASS * i][a_m / 4u][a_m % 4u] = a_reg[i];
#ifdef NN_CONV_F16_WEIGHTS
      if (b_loader) {
        gemm_b_tile[buf][b_k][2u * b_v] = vec4(unpackHalf2x16(b_reg.x), unpackHalf2x16(b_reg.y));
        gemm_b_tile[buf][b_k][2u * b_v + 1u] = vec4(unpackHalf2x16(b_reg.z), unpackHalf2x16(b_reg.w));
      }
#else
      gemm_b_tile[buf][b_k][b_v] = b_reg;
#endif
    }
    barrier();
  }
}
