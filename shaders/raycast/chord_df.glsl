// The semantic chord of the ray caster's float-only exact pass (raycast/exact_df.comp, through
// raycast/traverse.glsl) in double-float, also dispatched alone by the test kernel
// raycast/df_check.comp (tests/render/test_raycast_df.cpp: against the double formula).
#ifndef ICUBE_RAYCAST_CHORD_DF_GLSL
#define ICUBE_RAYCAST_CHORD_DF_GLSL

#include "shared/raycast_df_params.h"
#include "common/df.glsl"

// raycast_chord_f64's chord in double-float: the same formulas (camera-frame direction
// normalised, rotated, normalised, plane times from integer planes, the latest entry and the
// earliest exit clipped to the bounds and t_max), every operation in df (common/df.glsl) on the
// camera's doubles given as float pairs (camdf: shared/raycast_df_params.h), returned as a df.
// Relative voxel v, pixel pix, bounds [lo, hi) relative to the reference voxel, as in
// raycast/traverse.glsl.
// Why the decisions (chord >= eps_sem) equal the double reference's: both compute the same
// real-valued chord from the same inputs; the reference with ~20 double roundings (2^-53), this
// with ~20 df operations of relative error <= 10 u^2 (u = 2^-24; measured <= 3.3 u^2 by
// tests/render/test_raycast_df.cpp) on the inputs rounded to pairs (2^-48). The unit direction
// then carries an absolute error of about 30 u^2 ~ 1e-13 (rotation and normalisation included),
// each plane time t_a = (plane - o) · vs / d_a a relative one of about 1e-13 / |d_a|, and the
// chord (the difference of two plane times near the voxel's entry t, on the axes a, b whose
// planes bound it) an absolute one of about 1e-13 · t · (1 / |d_a| + 1 / |d_b|) metres (an upper
// estimate: tests/render/test_raycast_df.cpp measures at most 7e-15 · t · (...), 1.7e-11 m, on
// 40,000 voxels of random camera rays at t <= 120 m, and checks the 1e-13 · t · (...)), against
// the reference's own ~1e-15 · t · (...). So the two agree unless the reference's chord lies
// within that of eps_sem: ~3e-12 m at t = 10 m and ~3e-11 m at 100 m for planes crossed at more
// than 45°, ~3e-8 m at 100 m for a plane grazed at 1:1000 — against the float pass's 1e-6 + 1e-6 t
// window (~1e-5 to 1e-4 m), in which ~1 ray in 10^5 lands; a chord lands within the df margin
// ~10^3 (grazing) to 10^6 times less often. The float walk (which voxel the chord belongs to) is unchanged.
vec2 raycast_chord_df(RaycastCameraDf camdf, ivec3 v, uvec2 pix, ivec3 lo, ivec3 hi) {
  const vec2 one = vec2(1.0, 0.0);
  const vec2 dcx = df_div(df_sub(df_add(vec2(float(pix.x), 0.0), camdf.pixel_offset), camdf.cx), camdf.fx);
  const vec2 dcy = df_div(df_sub(df_add(vec2(float(pix.y), 0.0), camdf.pixel_offset), camdf.cy), camdf.fy);
  const vec2 inv_c = df_div(one, df_sqrt(df_add(df_add(df_mul(dcx, dcx), df_mul(dcy, dcy)), one)));
  const vec2 cx = df_mul(dcx, inv_c), cy = df_mul(dcy, inv_c), cz = inv_c;
  vec2 w[3];
  w[0] = df_add(df_add(df_mul(camdf.r00, cx), df_mul(camdf.r01, cy)), df_mul(camdf.r02, cz));
  w[1] = df_add(df_add(df_mul(camdf.r10, cx), df_mul(camdf.r11, cy)), df_mul(camdf.r12, cz));
  w[2] = df_add(df_add(df_mul(camdf.r20, cx), df_mul(camdf.r21, cy)), df_mul(camdf.r22, cz));
  const vec2 inv_w = df_div(one, df_sqrt(df_add(df_add(df_mul(w[0], w[0]), df_mul(w[1], w[1])), df_mul(w[2], w[2]))));
  const vec2 o[3] = vec2[3](camdf.off_x, camdf.off_y, camdf.off_z);
  vec2 t0 = vec2(0.0), t1 = camdf.t_max, te = vec2(0.0), tx = vec2(3.0e38, 0.0);
  for (int a = 0; a < 3; ++a) {
    // Plane time (plane - o) / (d / vs) = (plane - o) · k, k = vs / d (one division per axis).
    const vec2 da = df_mul(w[a], inv_w);
    if (da.x == 0.0) continue;
    const vec2 k = df_div(camdf.voxel_size, da);
    const vec2 ta = df_mul(df_sub(vec2(float(lo[a]), 0.0), o[a]), k);
    const vec2 tb = df_mul(df_sub(vec2(float(hi[a]), 0.0), o[a]), k);
    t0 = df_max(t0, df_min(ta, tb));
    t1 = df_min(t1, df_max(ta, tb));
    const bool fwd = da.x > 0.0;
    const vec2 tin = df_mul(df_sub(vec2(float(fwd ? v[a] : v[a] + 1), 0.0), o[a]), k);
    const vec2 tout = df_mul(df_sub(vec2(float(fwd ? v[a] + 1 : v[a]), 0.0), o[a]), k);
    te = df_max(te, tin);
    tx = df_min(tx, tout);
  }
  return df_max(df_sub(df_min(tx, t1), df_max(te, t0)), vec2(0.0));
}

#endif
