// Double-float ("df") arithmetic in plain fp32, for kernels that need about
// 48 significant bits on devices without shaderFloat64. A df value is a vec2
// (hi, lo) standing for the unevaluated sum hi + lo, normalised so that
// |lo| <= ulp(hi) / 2 (every function below returns normalised values).
//
// What it relies on: Vulkan's fp32 add, subtract and multiply are correctly
// rounded (the SPIR-V precision table), with round to nearest (every desktop
// GPU's and lavapipe's mode; kernels do not declare RTZ), and no operation
// is fused or reassociated: every float that an error-free transformation
// produces is `precise` (SPIR-V NoContraction, which Mesa's NIR keeps as
// "exact" ALU ops). Division and sqrt are not correctly rounded in Vulkan
// (2.5 ulp, and sqrt inherited from inversesqrt), so they only seed
// corrections computed with the exact operations:
//   df_two_sum   Knuth's TwoSum: s + e == a + b exactly (6 operations, any order of magnitude).
//   df_fast_two_sum  Dekker's Fast2Sum, for |a| >= |b| (or a == 0).
//   df_split     Veltkamp's splitting by 2^12 + 1: a == hi + lo exactly, each with at most 12
//                significant bits, so products of halves are exact in fp32.
//   df_two_prod  Dekker's TwoProduct: p + e == a * b exactly (no FMA needed; if a compiler did
//                fuse one of its products anyway, each is exact, so the result is the same).
//   df_add / df_sub  the accurate df sum (two TwoSums, two Fast2Sums): relative error
//                below 3 u^2 (u = 2^-24) even under cancellation.
//   df_mul, df_mul_f  Dekker's product (df x df, df x float): relative error below ~7 u^2.
//   df_div       long division: three fp32 quotient digits, each from the df remainder
//                (2.5-ulp fp32 division only decides digits, the remainder is exact to
//                df precision): relative error below ~10 u^2.
//   df_sqrt      fp32 sqrt refined by two Newton steps y += (a - y^2) / (2y) with df
//                remainders: relative error below ~10 u^2 for a > 0.
// Magnitudes must stay within ~[1e-15, 1e30] (the lo parts and the splitting
// factor must neither underflow nor overflow); the ray caster's are within
// [1e-10, 1e10].
//
// Users: shaders/raycast/traverse.glsl (raycast/exact_df.comp); the primitives are tested
// against long double through shaders/raycast/df_check.comp (tests/render/test_raycast_df.cpp).
#ifndef ICUBE_DF_GLSL
#define ICUBE_DF_GLSL

vec2 df_two_sum(float a, float b) {
  precise float s = a + b;
  precise float bb = s - a;
  precise float e = (a - (s - bb)) + (b - bb);
  return vec2(s, e);
}

vec2 df_fast_two_sum(float a, float b) {
  precise float s = a + b;
  precise float e = b - (s - a);
  return vec2(s, e);
}

vec2 df_split(float a) {
  precise float c = 4097.0 * a;
  precise float hi = c - (c - a);
  precise float lo = a - hi;
  return vec2(hi, lo);
}

vec2 df_two_prod(float a, float b) {
  precise float p = a * b;
  const vec2 x = df_split(a), y = df_split(b);
  precise float e = ((x.x * y.x - p) + x.x * y.y + x.y * y.x) + x.y * y.y;
  return vec2(p, e);
}

vec2 df_add(vec2 a, vec2 b) {
  const vec2 s = df_two_sum(a.x, b.x), t = df_two_sum(a.y, b.y);
  precise float c = s.y + t.x;
  const vec2 u = df_fast_two_sum(s.x, c);
  precise float w = u.y + t.y;
  return df_fast_two_sum(u.x, w);
}

vec2 df_sub(vec2 a, vec2 b) { return df_add(a, -b); }

vec2 df_mul(vec2 a, vec2 b) {
  const vec2 p = df_two_prod(a.x, b.x);
  precise float c = p.y + (a.x * b.y + a.y * b.x);
  return df_fast_two_sum(p.x, c);
}

vec2 df_mul_f(vec2 a, float b) {
  const vec2 p = df_two_prod(a.x, b);
  precise float c = p.y + a.y * b;
  return df_fast_two_sum(p.x, c);
}

vec2 df_div(vec2 a, vec2 b) {
  const float q1 = a.x / b.x;
  vec2 r = df_sub(a, df_mul_f(b, q1));
  const float q2 = r.x / b.x;
  r = df_sub(r, df_mul_f(b, q2));
  const float q3 = r.x / b.x;
  return df_add(df_fast_two_sum(q1, q2), vec2(q3, 0.0));
}

vec2 df_sqrt(vec2 a) {
  vec2 y = vec2(sqrt(a.x), 0.0);
  for (int k = 0; k < 2; ++k) {
    const vec2 r = df_sub(a, df_mul(y, y));
    y = df_add(y, vec2(r.x / (2.0 * y.x), 0.0));
  }
  return y;
}

// Order of normalised values (hi first; equal hi: lo).
bool df_less(vec2 a, vec2 b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }
vec2 df_min(vec2 a, vec2 b) { return df_less(b, a) ? b : a; }
vec2 df_max(vec2 a, vec2 b) { return df_less(a, b) ? b : a; }

#endif
