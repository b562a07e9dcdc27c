// The cooperative-matrix implicit-GEMM core of the GPU convolutions
// (conv3d_coopmat, sparse_conv_coopmat): a 64 x 64 block of
// C[m][n] = sum_k A[m][k] B[k][n] per workgroup of 4 subgroups of 32, each
// multiplying 2 x 2 fragments of 16 x 16 x 16 fp16 with fp32 accumulators
// (GL_NV_cooperative_matrix with NN_COOPMAT_NV). Each K step of 32 is gathered
// from A and the packed weights into fp16 shared tiles (the next step's global
// loads in flight during the multiplies); the finished block is staged in
// shared memory, column-major, so a caller's epilogue writes consecutive rows
// of one column per thread. A values are rounded to fp16 (|x| > 65504
// overflows, as in PyTorch's half precision).
// Without NN_COOPMAT_NV the same tiling runs with each fragment load,
// multiply-add and store written out per lane of a 32-invocation group: slow,
// it exists so lavapipe tests the kernels' tiles, offsets, strides and windows.
// B is the packed weight rows [k][output channels padded to 8] (vec4s, or
// uvec4s of 8 halves with NN_CONV_F16_WEIGHTS) at columns from p.co_begin.
// Expects before inclusion (the contract of nn/gemm_tiled.glsl): `p`
// (co_begin, co_vec4s), the binding `w_packed`, a row type GemmRow with
// GemmRow gemm_row(uint m) (m past the rows: a row whose A values are 0),
// float gemm_a(GemmRow r, uint k) (0 for k past k_count) and
// uint gemm_weight_row(uint k); local_size_x = NN_CONV_COOP_GROUP.
#extension GL_EXT_shader_explicit_arithmetic_types_float16 : require
#ifdef NN_COOPMAT_NV
#extension GL_NV_cooperative_matrix : require
#extension GL_KHR_memory_scope_semantics : require
#extension GL_KHR_shader_subgroup_basic : require
#endif

const uint GEMM_COOP_BM = NN_CONV_COOP_BM, GEMM_COOP_BN = NN_CONV_COOP_BN, GEMM_COOP_BK = NN_CONV_COOP_BK;
// Shared tiles, padded so rows start 16 bytes apart but not on the same banks:
// A column-major (m, k) at k * A_STRIDE + m; B row-major (k, n) at k * B_STRIDE + n;
// the result column-major (m, n) at n * C_STRIDE + m.
const uint GEMM_COOP_A_STRIDE = GEMM_COOP_BM + 8u, GEMM_COOP_B_STRIDE = GEMM_COOP_BN + 8u;
const uint GEMM_COOP_C_STRIDE = GEMM_COOP_BM + 4u;
shared float16_t gemm_coop_a_sh[GEMM_COOP_BK * GEMM_COOP_A_STRIDE];
shared float16_t gemm_coop_b_sh[GEMM_COOP_BK * GEMM_COOP_B_STRIDE];
shared float gemm_coop_c_sh[GEMM_COOP_BN * GEMM_COOP_C_STRIDE];

#ifdef NN_COOPMAT_NV
#define GemmFragA fcoopmatNV<16, gl_ScopeSubgroup, 16, 16>
#define GemmFragB fcoopmatNV<16, gl_ScopeSubgroup, 16, 16>
#define GemmFragC fcoopmatNV<32, gl_ScopeSubgroup, 16, 16>
#define GEMM_FRAG_ZERO(c) c = GemmFragC(0.0)
#define GEMM_FRAG_LOAD_A(f, off) coopMatLoadNV(f, gemm_coop_a_sh, off, GEMM_COOP_A_STRIDE, true)
#define GEMM_FRAG_LOAD_B(f, off) coopMatLoadNV(f, gemm_coop_b_sh, off, GEMM_COOP_B_STRIDE, false)
#define GEMM_FRAG_MMA(a, b, c) c = coopMatMulAddNV(a, b, c)
#define GEMM_FRAG_STORE_C(c, off) coopMatStoreNV(c, gemm_coop_c_sh, off, GEMM_COOP_C_STRIDE, true)
uint gemm_coop_warp() { return gl_SubgroupID; }  // the host requires subgroups of 32
#else
// Emulated fragments: an A or B fragment is its offset in shared memory (read
// at the multiply, which comes before the step's closing barrier, as the
// cooperative load does); an accumulator holds 8 of its 16 x 16 values per
// lane of a 32-lane group: row lane / 2, columns (lane % 2) * 8 + e.
struct GemmEmulatedAcc { float v[8]; };
#define GemmFragA uint
#define GemmFragB uint
#define GemmFragC GemmEmulatedAcc
#define GEMM_FRAG_ZERO(c) for (uint e_ = 0u; e_ < 8u; ++e_) c.v[e_] = 0.0
#define GEMM_FRAG_LOAD_A(f, off) f = (off)
#define GEMM_FRAG_LOAD_B(f, off) f = (off)
#define GEMM_FRAG_MMA(a, b, c) gemm_emulated_mma(a, b, c)
#define GEMM_FRAG_STORE_C(c, off) gemm_emulated_store(c, off)
uint gemm_coop_warp() { return gl_LocalInvocationID.x / 32u; }
void gemm_emulated_mma(uint a_off, uint b_off, inout GemmEmulatedAcc c) {
  const uint lane = gl_LocalInvocationID.x % 32u, r = lane / 2u, c0 = (lane % 2u) * 8u;
  for (uint e = 0u; e < 8u; ++e) {
    float s = c.v[e];
    for (uint kk = 0u; kk < 16u; ++kk)
      s = fma(float(gemm_coop_a_sh[a_off + kk * GEMM_COOP_A_STRIDE + r]),
              float(gemm_coop_b_sh[b_off + kk * GEMM_COOP_B_STRIDE + c0 + e]), s);
    c.v[e] = s;
  }
}
void gemm_emulated_store(GemmEmulatedAcc c, uint off) {
  const uint lane = gl_LocalInvocationID.x % 32u, r = lane / 2u, c0 = (lane % 2u) * 8u;
  for (uint e = 0u; e < 8u; ++e) gemm_coop_c_sh[off + (c0 + e) * GEMM_COOP_C_STRIDE + r] = c.v[e];
}
#endif

const uint GEMM_COOP_A_ROWS_PER_PASS = NN_CONV_COOP_GROUP / GEMM_COOP_BM;    // 2
const uint GEMM_COOP_A_LOADS = GEMM_COOP_BK / GEMM_COOP_A_ROWS_PER_PASS;     // 16 A values per thread and step
#ifdef NN_CONV_F16_WEIGHTS
const uint GEMM_COOP_B_VECS = GEMM_COOP_BN / 8u;  // uvec4s per B row
#define GemmWeightVec uvec4
#define GEMM_WEIGHT_ZERO uvec4(0u)
#else
const uint GEMM_COOP_B_VECS = GEMM_COOP_BN / 4u;  // vec4s per B row
#define GemmWeightVec vec4
#define GEMM_WEIGHT_ZERO vec4(0.0)
#endif
const uint GEMM_COOP_B_ROWS_PER_PASS = NN_CONV_COOP_GROUP / GEMM_COOP_B_VECS;
const uint GEMM_COOP_B_LOADS = GEMM_COOP_BK / GEMM_COOP_B_ROWS_PER_PASS;

// The epilogue's roles: thread t writes row gemm_coop_out_m() of columns gemm_coop_out_n0(), + 2, + 4, ...
uint gemm_coop_out_m() { return gl_LocalInvocationID.x % GEMM_COOP_BM; }
uint gemm_coop_out_n0() { return gl_LocalInvocationID.x / GEMM_COOP_BM; }
const uint GEMM_COOP_OUT_N_STEP = GEMM_COOP_A_ROWS_PER_PASS;
// The finished block's value at row m, column n (after gemm_coopmat returned).
float gemm_coop_c(uint m, uint n) { return gemm_coop_c_sh[n * GEMM_COOP_C_STRIDE + m]; }

// The block of rows m_base.. and column block `cob` (64 channels from p.co_begin + 64 cob), left in
// shared memory for gemm_coop_c. Every thread of the workgroup must call it; it ends with a barrier.
void gemm_coopmat(uint m_base, uint cob, uint k_count) {
  const uint tid = gl_LocalInvocationID.x;
  const uint a_m = tid % GEMM_COOP_BM, a_k0 = tid / GEMM_COOP_BM;
  const GemmRow row = gemm_row(m_base + a_m);
  const uint b_k0 = tid / GEMM_COOP_B_VECS, b_v = tid % GEMM_COOP_B_VECS;
#ifdef NN_CONV_F16_WEIGHTS
  const uint row_len = p.co_vec4s / 2u;
  const uint b_c = (p.co_begin + cob * GEMM_COOP_BN) / 8u + b_v;
#else
  const uint row_len = p.co_vec4s;
  const uint b_c = (p.co_begin + cob * GEMM_COOP_BN) / 4u + b_v;
#endif
  GemmWeightVec b_reg[GEMM_COOP_B_LOADS];
  float a_reg[GEMM_COOP_A_LOADS];

  // This subgroup's 32 x 32 quarter of the block: rows 32 wm.., columns 32 wn...
  const uint w = gemm_coop_warp(), wm = w % 2u, wn = w / 2u;
  GemmFragC acc[2][2];
  for (uint i = 0u; i < 2u; ++i)
    for (uint j = 0u; j < 2u; ++j) GEMM_FRAG_ZERO(acc[i][j]);

  const uint steps = (k_count + GEMM_COOP_BK - 1u) / GEMM_COOP_BK;
  for (uint t = 0u; t < steps; ++t) {
    // Global loads of step t (step 0 here; later steps were prefetched below).
    if (t == 0u) {
      for (uint i = 0u; i < GEMM_COOP_A_LOADS; ++i) a_reg[i] = gemm_a(row, a_k0 + GEMM_COOP_A_ROWS_PER_PASS * i);
      for (uint i = 0u; i < GEMM_COOP_B_LOADS; ++i) {
        const uint k = b_k0 + GEMM_COOP_B_ROWS_PER_PASS * i;
        b_reg[i] = k < k_count && b_c < row_len ? w_packed[gemm_weight_row(k) * row_len + b_c] : GEMM_WEIGHT_ZERO;
      }
    }
    for (uint i = 0u; i < GEMM_COOP_A_LOADS; ++i)
      gemm_coop_a_sh[(a_k0 + GEMM_COOP_A_ROWS_PER_PASS * i) * GEMM_COOP_A_STRIDE + a_m] = float16_t(a_reg[i]);
    for (uint i = 0u; i < GEMM_COOP_B_LOADS; ++i) {
      const uint row_off = (b_k0 + GEMM_COOP_B_ROWS_PER_PASS * i) * GEMM_COOP_B_STRIDE;
#ifdef NN_CONV_F16_WEIGHTS
      const uint n = row_off + 8u * b_v;
      const f16vec2 h0 = unpackFloat2x16(b_reg[i].x), h1 = unpackFloat2x16(b_reg[i].y);
      const f16vec2 h2 = unpackFloat2x16(b_reg[i].z), h3 = unpackFloat2x16(b_reg[i].w);
      gemm_coop_b_sh[n] = h0.x; gemm_coop_b_sh[n + 1u] = h0.y; gemm_coop_b_sh[n + 2u] = h1.x;
      gemm_coop_b_sh[n + 3u] = h1.y; gemm_coop_b_sh[n + 4u] = h2.x; gemm_coop_b_sh[n + 5u] = h2.y;
      gemm_coop_b_sh[n + 6u] = h3.x; gemm_coop_b_sh[n + 7u] = h3.y;
#else
      const uint n = row_off + 4u * b_v;
      gemm_coop_b_sh[n] = float16_t(b_reg[i].x); gemm_coop_b_sh[n + 1u] = float16_t(b_reg[i].y);
      gemm_coop_b_sh[n + 2u] = float16_t(b_reg[i].z); gemm_coop_b_sh[n + 3u] = float16_t(b_reg[i].w);
#endif
    }
    barrier();
    // Prefetch step t + 1 while the fragments multiply.
    if (t + 1u < steps) {
      const uint k0 = (t + 1u) * GEMM_COOP_BK;
      for (uint i = 0u; i < GEMM_COOP_A_LOADS; ++i) a_reg[i] = gemm_a(row, k0 + a_k0 + GEMM_COOP_A_ROWS_PER_PASS * i);
      for (uint i = 0u; i < GEMM_COOP_B_LOADS; ++i) {
        const uint k = k0 + b_k0 + GEMM_COOP_B_ROWS_PER_PASS * i;
        b_reg[i] = k < k_count && b_c < row_len ? w_packed[gemm_weight_row(k) * row_len + b_c] : GEMM_WEIGHT_ZERO;
      }
    }
    for (uint kk = 0u; kk < GEMM_COOP_BK; kk += 16u) {
      GemmFragA fa[2];
      GemmFragB fb[2];
      for (uint i = 0u; i < 2u; ++i) GEMM_FRAG_LOAD_A(fa[i], kk * GEMM_COOP_A_STRIDE + 32u * wm + 16u * i);
      for (uint j = 0u; j < 2u; ++j) GEMM_FRAG_LOAD_B(fb[j], kk * GEMM_COOP_B_STRIDE + 32u * wn + 16u * j);
      for (uint i = 0u; i < 2u; ++i)
        for (uint j = 0u; j < 2u; ++j) GEMM_FRAG_MMA(fa[i], fb[j], acc[i][j]);
    }
    barrier();
  }

  for (uint i = 0u; i < 2u; ++i)
    for (uint j = 0u; j < 2u; ++j)
      GEMM_FRAG_STORE_C(acc[i][j], (32u * wn + 16u * j) * GEMM_COOP_C_STRIDE + 32u * wm + 16u * i);
  barrier();
}
