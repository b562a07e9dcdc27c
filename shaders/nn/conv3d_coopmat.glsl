// conv3d_coopmat's body, shared by nn/conv3d_coopmat.comp (NN_COOPMAT_NV:
// GL_NV_cooperative_matrix) and nn/conv3d_coopmat_emulated.comp (the same
// tiling with each fragment operation written out per lane, so the kernel's
// indexing runs and is tested on devices without cooperative matrices); see
// conv3d_coopmat.comp.
#extension GL_EXT_shader_explicit_arithmetic_types_float16 : require
#ifdef NN_COOPMAT_NV
#extension GL_NV_cooperative_matrix : require
#extension GL_KHR_memory_scope_semantics : require
#extension GL_KHR_shader_subgroup_basic : require
#endif
#include "conv3d_bindings.glsl"

layout(local_size_x = NN_CONV_COOP_GROUP) in;

#include "conv3d_operands.glsl"

const uint BM = NN_CONV_COOP_BM, BN = NN_CONV_COOP_BN, BK = NN_CONV_COOP_BK;
// Shared tiles, padded so rows start 16 bytes apart but not on the same banks:
// A column-major (m, k) at k * A_STRIDE + m; B row-major (k, n) at k * B_STRIDE + n;
// the result column-major (m, n) at n * C_STRIDE + m (each thread then writes
// consecutive voxels of one channel).
const uint A_STRIDE = BM + 8u, B_STRIDE = BN + 8u, C_STRIDE = BM + 4u;
shared float16_t a_sh[BK * A_STRIDE];
shared float16_t b_sh[BK * B_STRIDE];
shared float c_sh[BN * C_STRIDE];

#ifdef NN_COOPMAT_NV
#define FragA fcoopmatNV<16, gl_ScopeSubgroup, 16, 16>
#define FragB fcoopmatNV<16, gl_ScopeSubgroup, 16, 16>
#define FragC fcoopmatNV<32, gl_ScopeSubgroup, 16, 16>
#define FRAG_ZERO(c) c = FragC(0.0)
#define FRAG_LOAD_A(f, off) coopMatLoadNV(f, a_sh, off, A_STRIDE, true)
#define FRAG_LOAD_B(f, off) coopMatLoadNV(f, b_sh, off, B_STRIDE, false)
#define FRAG_MMA(a, b, c) c = coopMatMulAddNV(a, b, c)
#define FRAG_STORE_C(c, off) coopMatStoreNV(c, c_sh, off, C_STRIDE, true)
uint warp_index() { return gl_SubgroupID; }  // the host requires subgroups of 32
#else
// Emulated fragments: an A or B fragment is its offset in shared memory (read
// at the multiply, which comes before the step's closing barrier, as the
// cooperative load does); an accumulator holds 8 of its 16 x 16 values per
// lane of a 32-lane group: row lane / 2, columns (lane % 2) * 8 + e.
struct EmulatedAcc { float v[8]; };
#define FragA uint
#define FragB uint
#define FragC EmulatedAcc
#define FRAG_ZERO(c) for (uint e_ = 0u; e_ < 8u; ++e_) c.v[e_] = 0.0
#define FRAG_LOAD_A(f, off) f = (off)
#define FRAG_LOAD_B(f, off) f = (off)
#define FRAG_MMA(a, b, c) emulated_mma(a, b, c)
#define FRAG_STORE_C(c, off) emulated_store(c, off)
uint warp_index() { return gl_LocalInvocationID.x / 32u; }
void emulated_mma(uint a_off, uint b_off, inout EmulatedAcc c) {
  const uint lane = gl_LocalInvocationID.x % 32u, r = lane / 2u, c0 = (lane % 2u) * 8u;
  for (uint e = 0u; e < 8u; ++e) {
    float s = c.v[e];
    for (uint kk = 0u; kk < 16u; ++kk)
      s = fma(float(a_sh[a_off + kk * A_STRIDE + r]), float(b_sh[b_off + kk * B_STRIDE + c0 + e]), s);
    c.v[e] = s;
  }
}
void emulated_store(EmulatedAcc c, uint off) {
  const uint lane = gl_LocalInvocationID.x % 32u, r = lane / 2u, c0 = (lane % 2u) * 8u;
  for (uint e = 0u; e < 8u; ++e) c_sh[off + (c0 + e) * C_STRIDE + r] = c.v[e];
}
#endif

const uint A_ROWS_PER_PASS = NN_CONV_COOP_GROUP / BM;  // 2
const uint A_LOADS = BK / A_ROWS_PER_PASS;            // 16 A values per thread and step
#ifdef NN_CONV_F16_WEIGHTS
const uint B_VECS = BN / 8u;                          // uvec4s per B row
#else
const uint B_VECS = BN / 4u;                          // vec4s per B row
#endif
const uint B_ROWS_PER_PASS = NN_CONV_COOP_GROUP / B_VECS;
const uint B_LOADS = BK / B_ROWS_PER_PASS;

void main() {
  const ConvBlock blk = conv_block();
  const uint tile = blk.tile, cob = blk.cob, b = blk.batch;
  if (b >= p.batch) return;  // uniform across the workgroup
  const uint tid = gl_LocalInvocationID.x;
  const uint S = p.size_x * p.size_y * p.size_z;
  const uint k_count = p.ci_count * NN_TAPS;
  const uint x_base = p.x_offset + b * p.x_batch_stride;

  const uint a_m = tid % BM, a_k0 = tid / BM;
  const ConvVoxel av = conv_voxel(tile * BM + a_m);
  const uint b_k0 = tid / B_VECS, b_v = tid % B_VECS;
#ifdef NN_CONV_F16_WEIGHTS
  const uint row_len = p.co_vec4s / 2u;
  const uint b_c = (p.co_begin + cob * BN) / 8u + b_v;
  uvec4 b_reg[B_LOADS];
#else
  const uint row_len = p.co_vec4s;
  const uint b_c = (p.co_begin + cob * BN) / 4u + b_v;
  vec4 b_reg[B_LOADS];
#endif
  float a_reg[A_LOADS];

  // This subgroup's 32 x 32 quarter of the block: rows 32 wm.., columns 32 wn...
  const uint w = warp_index(), wm = w % 2u, wn = w / 2u;
  FragC acc[2][2];
  for (uint i = 0u; i < 2u; ++i)
    for (uint j = 0u; j < 2u; ++j) FRAG_ZERO(acc[i][j]);

  const uint steps = (k_count + BK - 1u) / BK;
  for (uint t = 0u; t < steps; ++t) {
    // Global loads of step t (step 0 before the loop's first store; later steps were prefetched below).
    if (t == 0u) {
      for (uint i = 0u; i < A_LOADS; ++i) a_reg[i] = conv_a(av, a_k0 + A_ROWS_PER_PASS * i, k_count, x_base);
      for (uint i = 0u; i < B_LOADS; ++i) {
        const uint k = b_k0 + B_ROWS_PER_PASS * i;
#ifdef NN_CONV_F16_WEIGHTS
        b_reg[i] = k < k_count && b_c < row_len ? w_packed[conv_weight_row(k) * row_len + b_c] : uvec4(0u);
#else
        b_reg[i] = k < k_count && b_c < row_len ? w_packed[conv_weight_row(k) * row_len + b_c] : vec4(0.0);
#endif
      }
    }
    for (uint i = 0u; i < A_LOADS; ++i) a_sh[(a_k0 + A_ROWS_PER_PASS * i) * A_STRIDE + a_m] = float16_t(a_reg[i]);
    for (uint i = 0u; i < B_LOADS; ++i) {
      const uint row = (b_k0 + B_ROWS_PER_PASS * i) * B_STRIDE;
#ifdef NN_CONV_F16_WEIGHTS
      const uint n = row + 8u * b_v;
      const f16vec2 h0 = unpackFloat2x16(b_reg[i].x), h1 = unpackFloat2x16(b_reg[i].y);
      const f16vec2 h2 = unpackFloat2x16(b_reg[i].z), h3 = unpackFloat2x16(b_reg[i].w);
      b_sh[n] = h0.x; b_sh[n + 1u] = h0.y; b_sh[n + 2u] = h1.x; b_sh[n + 3u] = h1.y;
      b_sh[n + 4u] = h2.x; b_sh[n + 5u] = h2.y; b_sh[n + 6u] = h3.x; b_sh[n + 7u] = h3.y;
#else
      const uint n = row + 4u * b_v;
      b_sh[n] = float16_t(b_reg[i].x); b_sh[n + 1u] = float16_t(b_reg[i].y);
      b_sh[n + 2u] = float16_t(b_reg[i].z); b_sh[n + 3u] = float16_t(b_reg[i].w);
#endif
    }
    barrier();
    // Prefetch step t + 1 while the fragments multiply.
    if (t + 1u < steps) {
      const uint k0 = (t + 1u) * BK;
      for (uint i = 0u; i < A_LOADS; ++i) a_reg[i] = conv_a(av, k0 + a_k0 + A_ROWS_PER_PASS * i, k_count, x_base);
      for (uint i = 0u; i < B_LOADS; ++i) {
        const uint k = k0 + b_k0 + B_ROWS_PER_PASS * i;
#ifdef NN_CONV_F16_WEIGHTS
        b_reg[i] = k < k_count && b_c < row_len ? w_packed[conv_weight_row(k) * row_len + b_c] : uvec4(0u);
#else
        b_reg[i] = k < k_count && b_c < row_len ? w_packed[conv_weight_row(k) * row_len + b_c] : vec4(0.0);
#endif
      }
    }
    for (uint kk = 0u; kk < BK; kk += 16u) {
      FragA fa[2];
      FragB fb[2];
      for (uint i = 0u; i < 2u; ++i) FRAG_LOAD_A(fa[i], kk * A_STRIDE + 32u * wm + 16u * i);
      for (uint j = 0u; j < 2u; ++j) FRAG_LOAD_B(fb[j], kk * B_STRIDE + 32u * wn + 16u * j);
      for (uint i = 0u; i < 2u; ++i)
        for (uint j = 0u; j < 2u; ++j) FRAG_MMA(fa[i], fb[j], acc[i][j]);
    }
    barrier();
  }

  for (uint i = 0u; i < 2u; ++i)
    for (uint j = 0u; j < 2u; ++j) FRAG_STORE_C(acc[i][j], (32u * wn + 16u * j) * C_STRIDE + 32u * wm + 16u * i);
  barrier();
  const uint m = tile * BM + a_m;
  if (m >= S) return;
  for (uint n = a_k0; n < BN; n += A_ROWS_PER_PASS) {
    const uint cl = cob * BN + n;  // channel within the window
    if (cl >= p.co_count) break;
    const uint yi = p.y_offset + b * p.y_batch_stride + cl * S + m;
    const float v = c_sh[n * C_STRIDE + a_m];
    if (p.accumulate != 0u) y_out[yi] += v;
    else y_out[yi] = v + (p.has_bias != 0u ? bias[p.co_begin + cl] : 0.0);
  }
}
