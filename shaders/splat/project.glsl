// Gaussian splatting preprocessing of one Gaussian (EWA projection, radius,
// tile rect, SH colour). Mirrors engine/splat/rasterizer_cpu.cpp
// project_gaussian() operation by operation; conventions in
// engine/splat/rasterizer_cpu.h. Included by shaders/splat/preprocess.comp,
// which declares the push constants `p` (SplatPreprocessParams),
// `float splat_sh_coeff(uint o)` (coefficient o of the Gaussian's SH row) and
// the constant SPLAT_SH_DEGREE (the bands evaluated).
#ifndef ICUBE_SPLAT_PROJECT_GLSL
#define ICUBE_SPLAT_PROJECT_GLSL

const float SH_C0 = 0.28209479177387814;
const float SH_C1 = 0.4886025119029199;
const float SH_C2_0 = 1.0925484305920792, SH_C2_1 = -1.0925484305920792, SH_C2_2 = 0.31539156525252005,
            SH_C2_3 = -1.0925484305920792, SH_C2_4 = 0.5462742152960396;
const float SH_C3_0 = -0.5900435899266435, SH_C3_1 = 2.890611442640554, SH_C3_2 = -0.4570457994644658,
            SH_C3_3 = 0.3731763325901154, SH_C3_4 = -0.4570457994644658, SH_C3_5 = 1.445305721320277,
            SH_C3_6 = -0.5900435899266435;

vec3 splat_sh(int k) {
  const uint o = uint(3 * k);
  return vec3(splat_sh_coeff(o), splat_sh_coeff(o + 1u), splat_sh_coeff(o + 2u));
}

vec3 splat_sh_color(uint degree, vec3 dir) {
  vec3 c = SH_C0 * splat_sh(0);
  if (degree > 0u) {
    const float x = dir.x, y = dir.y, z = dir.z;
    c = c - SH_C1 * y * splat_sh(1) + SH_C1 * z * splat_sh(2) - SH_C1 * x * splat_sh(3);
    if (degree > 1u) {
      const float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
      c = c + SH_C2_0 * xy * splat_sh(4) + SH_C2_1 * yz * splat_sh(5) +
          SH_C2_2 * (2.0 * zz - xx - yy) * splat_sh(6) + SH_C2_3 * xz * splat_sh(7) +
          SH_C2_4 * (xx - yy) * splat_sh(8);
      if (degree > 2u) {
        c = c + SH_C3_0 * y * (3.0 * xx - yy) * splat_sh(9) + SH_C3_1 * xy * z * splat_sh(10) +
            SH_C3_2 * y * (4.0 * zz - xx - yy) * splat_sh(11) +
            SH_C3_3 * z * (2.0 * zz - 3.0 * xx - 3.0 * yy) * splat_sh(12) +
            SH_C3_4 * x * (4.0 * zz - xx - yy) * splat_sh(13) + SH_C3_5 * z * (xx - yy) * splat_sh(14) +
            SH_C3_6 * x * (xx - 3.0 * yy) * splat_sh(15);
      }
    }
  }
  return max(c + 0.5, vec3(0.0));
}

bool splat_finite(float v) { return !isnan(v) && !isinf(v); }

// out0 = (mean_x, mean_y, depth, opacity), out1 = (conic, radius), out2 = (rgb, 0),
// rect = tile rect [x0, x1) × [y0, y1). Returns false (culled) with everything zero.
bool splat_project(vec3 d, float opacity, float cov[6], out vec4 out0, out vec4 out1, out vec4 out2,
                   out uvec4 rect) {
  out0 = vec4(0.0);
  out1 = vec4(0.0);
  out2 = vec4(0.0);
  rect = uvec4(0u);
  const vec3 r0 = vec3(p.r00, p.r01, p.r02), r1 = vec3(p.r10, p.r11, p.r12), r2 = vec3(p.r20, p.r21, p.r22);
  const float tx = r0.x * d.x + r0.y * d.y + r0.z * d.z;
  const float ty = r1.x * d.x + r1.y * d.y + r1.z * d.z;
  const float tz = r2.x * d.x + r2.y * d.y + r2.z * d.z;
  if (!(tz > p.near_z) || !(tz <= p.far_z)) return false;
  const float inv_z = 1.0 / tz;
  const float cxz = clamp(tx * inv_z, -p.lim_x_neg, p.lim_x_pos) * tz;
  const float cyz = clamp(ty * inv_z, -p.lim_y_neg, p.lim_y_pos) * tz;
  const float j00 = p.fx * inv_z, j02 = -p.fx * cxz * (inv_z * inv_z);
  const float j11 = p.fy * inv_z, j12 = -p.fy * cyz * (inv_z * inv_z);
  const vec3 m0 = j00 * r0 + j02 * r2;
  const vec3 m1 = j11 * r1 + j12 * r2;
  const vec3 s0 = vec3(cov[0] * m0.x + cov[1] * m0.y + cov[2] * m0.z, cov[1] * m0.x + cov[3] * m0.y + cov[4] * m0.z,
                       cov[2] * m0.x + cov[4] * m0.y + cov[5] * m0.z);
  const vec3 s1 = vec3(cov[0] * m1.x + cov[1] * m1.y + cov[2] * m1.z, cov[1] * m1.x + cov[3] * m1.y + cov[4] * m1.z,
                       cov[2] * m1.x + cov[4] * m1.y + cov[5] * m1.z);
  const float a0 = m0.x * s0.x + m0.y * s0.y + m0.z * s0.z;
  const float b = m0.x * s1.x + m0.y * s1.y + m0.z * s1.z;
  const float c0 = m1.x * s1.x + m1.y * s1.y + m1.z * s1.z;
  const float a = a0 + p.eps2d, c = c0 + p.eps2d;
  const float det = a * c - b * b;
  if (!(det > 0.0) || !splat_finite(det)) return false;
  float op = opacity;
  if (p.antialiased != 0u) op = op * sqrt(max(2.5e-5, (a0 * c0 - b * b) / det));
  if (!(op >= 1.0 / 255.0)) return false;
  const float det_inv = 1.0 / det;
  const float mid = 0.5 * (a + c);
  const float l1 = mid + sqrt(max(0.1, mid * mid - det));
  const float l2 = mid - sqrt(max(0.1, mid * mid - det));
  const float radius = ceil(3.0 * sqrt(max(l1, l2)));
  const float mx = p.fx * tx * inv_z + p.cx;
  const float my = p.fy * ty * inv_z + p.cy;
  if (!splat_finite(mx) || !splat_finite(my) || !splat_finite(radius) || !splat_finite(det_inv)) return false;
  // Whole-image tile coordinates, rows clamped to the band [tile_y0, tile_y0 + grid_y).
  const vec2 g0 = vec2(0.0, float(p.tile_y0)), g1 = vec2(float(p.grid_x), float(p.tile_y0 + p.grid_y));
  const uvec2 lo = uvec2(clamp((vec2(mx, my) - radius) / 16.0, g0, g1));
  uvec2 hi = uvec2(clamp((vec2(mx, my) + radius + 15.0) / 16.0, g0, g1));
  hi = max(hi, lo);
  if ((hi.x - lo.x) * (hi.y - lo.y) == 0u) return false;
  const float len = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  const vec3 dir = len > 0.0 ? d / len : vec3(0.0, 0.0, 1.0);
  out0 = vec4(mx, my, tz, op);
  out1 = vec4(c * det_inv, -b * det_inv, a * det_inv, radius);
  out2 = vec4(splat_sh_color(SPLAT_SH_DEGREE, dir), 0.0);
  rect = uvec4(lo, hi);
  return true;
}

#endif
