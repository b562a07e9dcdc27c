#version 460
#extension GL_GOOGLE_include_directive : require
// splat_lidar_bin: one invocation per Gaussian; which range-image tiles
// (SPLAT_LIDAR_TILE_ROWS rings x SPLAT_LIDAR_TILE_COLS columns) its cut
// sphere (centre μ, radius r_cut, engine/splat/lidar_gaussians_cpu.h) can
// reach, and the sort key of its instances.
// In the sensor frame (m_s = Sᵀ(μ − o), distance D = |m_s|) the rays within
// r_cut of μ form the cone of half-angle β = asin(r_cut / D) around m_s; its
// elevation range is [el − β, el + β] and its azimuth half-width
// asin(sin β / cos el) (all azimuths when the cone holds a pole); a small
// angular margin keeps the float binning conservative (the cast kernel tests
// each ray exactly). A Gaussian whose sphere contains the sensor touches every
// tile. Rings: the beams whose elevation is inside the range (binary search,
// elevations decreasing in ring order). Columns: azimuth(c) = start − 2π(c +
// 0.5)/C (lidar_model.h), so the azimuth interval is a column interval that
// may cross column C−1 → 0 (the ±180° wrap behind the sensor): it is stored as
// a run of tile columns from tx0, `count` long, wrapping modulo tiles_x (never
// longer than tiles_x, so no tile twice).
// Culled (0 tiles): r_cut = 0 (opacity < 1/255), t* bounds [D − r, D + r]
// outside [min_range, max_range], or no ray inside the cone.
// Outputs per Gaussian: rect = (ty0, ty1, tx0, count), touched = rows ·
// count, bound = max(0, D − r_cut) (a lower bound of t* for every ray it
// contributes to: the cast kernel's merge key).
// Host module: engine/splat/lidar_gaussians_gpu.cpp; test: tests/splat/test_lidar_gaussians.cpp.
#include "shared/splat_lidar_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatLidarParams p; };
#define LIDAR_GAUSSIAN_BINDING 0  // bindings 0-3: the Gaussian windows
#include "splat/lidar_gaussians.glsl"
layout(std430, binding = 4) readonly buffer Elevations { float elev[]; };  // radians, ring order
layout(std430, binding = 5) writeonly buffer Rects { uvec4 rects[]; };
layout(std430, binding = 6) writeonly buffer Touched { uint touched[]; };
layout(std430, binding = 7) writeonly buffer Bound { float bound[]; };

const float kPi = 3.14159265358979;
const float kMargin = 2e-4;  // radians

// Number of rings with elevation > x (strict) or >= x.
uint rings_above(float x, bool inclusive) {
  uint lo = 0u, hi = p.beams;
  while (lo < hi) {
    const uint mid = (lo + hi) >> 1;
    const float e = elev[mid];
    if (e > x || (inclusive && e == x)) lo = mid + 1u; else hi = mid;
  }
  return lo;
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.n) return;
  const vec4 g0 = gaussian_vec4(i, 0u);
  const float r = gaussian_vec4(i, 2u).w;
  uvec4 rect = uvec4(0u);
  uint count = 0u;
  float key = 0.0;
  const vec3 mw = g0.xyz - vec3(p.ox, p.oy, p.oz);
  // Sᵀ · m (S is row-major in the push constants).
  const vec3 ms = vec3(p.s00 * mw.x + p.s10 * mw.y + p.s20 * mw.z, p.s01 * mw.x + p.s11 * mw.y + p.s21 * mw.z,
                       p.s02 * mw.x + p.s12 * mw.y + p.s22 * mw.z);
  const float dist = length(ms);
  key = max(0.0, dist - r);
  if (r > 0.0 && dist - r <= p.max_range && dist + r >= p.min_range) {
    int r0 = 0, r1 = int(p.beams) - 1;
    bool all_cols = false;
    int c_lo = 0, len = 0;
    if (dist <= r * 1.001 + 1e-4) {
      all_cols = true;
    } else {
      const float beta = asin(min(1.0, r / dist)) + kMargin;
      const float el = asin(clamp(ms.z / dist, -1.0, 1.0));
      const float hi = el + beta, lo = el - beta;
      r0 = int(rings_above(hi, false));
      r1 = int(rings_above(lo, true)) - 1;
      const float ce = cos(el);
      const float sa = sin(beta) / max(ce, 1e-30);
      if (hi >= 0.5 * kPi || lo <= -0.5 * kPi || sa >= 1.0) {
        all_cols = true;
      } else {
        const float daz = asin(sa) + kMargin;
        const float az = atan(ms.y, ms.x);
        const float cpr = float(p.columns) / (2.0 * kPi);  // columns per radian
        const float u_lo = (p.start_azimuth - (az + daz)) * cpr - 0.5;
        const float u_hi = (p.start_azimuth - (az - daz)) * cpr - 0.5;
        c_lo = int(ceil(u_lo));
        len = int(floor(u_hi)) - c_lo + 1;
        if (len >= int(p.columns)) all_cols = true;
      }
    }
    uint tx0 = 0u, ncols = 0u;
    if (all_cols) {
      ncols = p.tiles_x;
    } else if (len > 0) {
      const int C = int(p.columns);
      // c_lo mod C with non-negative operands only: GLSL leaves % of a negative operand
      // undefined, and NVIDIA's driver returned wrong columns at the wrap with it.
      const int cl = c_lo >= 0 ? c_lo % C : C - 1 - (-(c_lo + 1)) % C;
      const int ce = cl + len - 1;
      const int t0 = cl / SPLAT_LIDAR_TILE_COLS;
      if (ce < C) {
        tx0 = uint(t0);
        ncols = uint(ce / SPLAT_LIDAR_TILE_COLS - t0 + 1);
      } else {
        const int t1 = (ce - C) / SPLAT_LIDAR_TILE_COLS;
        if (t1 >= t0) {
          ncols = p.tiles_x;
        } else {
          tx0 = uint(t0);
          ncols = p.tiles_x - uint(t0) + uint(t1) + 1u;
        }
      }
    }
    if (r0 <= r1 && ncols > 0u) {
      const uint ty0 = uint(r0) / SPLAT_LIDAR_TILE_ROWS, ty1 = uint(r1) / SPLAT_LIDAR_TILE_ROWS;
      rect = uvec4(ty0, ty1, tx0, ncols);
      count = (ty1 - ty0 + 1u) * ncols;
    }
  }
  rects[i] = rect;
  touched[i] = count;
  bound[i] = key;
}
