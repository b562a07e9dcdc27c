#version 460
#extension GL_GOOGLE_include_directive : require
// splat_lidar_cast: one invocation per LiDAR ray; composites the Gaussians of
// its range-image tile front to back (maths and rules in
// engine/splat/lidar_gaussians_cpu.h: t* = d'·m'/|d'|², q² = |m'×d'|²/|d'|²,
// α = min(0.99, o·exp(−½q²)), skip α < 1/255 and t* outside [min, max], stop
// before T·(1−α) < 1e-4, median at T <= 0.5).
// Order: the tile's instance list is sorted by each Gaussian's lower bound
// of t* (max(0, D − r_cut), splat/lidar_bin.comp), not by t* itself. The ray
// keeps up to SPLAT_LIDAR_K pending contributors in registers, sorted by
// (t*, Gaussian index), and composites one as soon as its t* is below the
// next list entry's bound (no later entry can come before it). When more
// than K are pending, the largest is dropped and everything after it is left
// for another pass over the list (from the first list entry not finished),
// which takes only contributors after the last composited one: the order is
// always the (t*, index) order of the CPU reference (up to the float rounding
// of t*; SPLAT_LIDAR_FLAG_OVERFLOW marks rays that needed more than one pass).
// After SPLAT_LIDAR_MAX_PASSES passes the rest is dropped
// (SPLAT_LIDAR_FLAG_TRUNCATED: the farthest contributors are missing).
// Invocations are numbered tile-major (64 per tile: ring = ty·4 + l/16,
// column = tx·16 + l%16), so a subgroup shares one tile's list and its loads.
// Positions are relative to the scene origin and the sensor origin is split
// against the same origin on the host (100 km from the origin casts the
// same). No shared memory or barriers (slow on lavapipe).
// Output: SplatLidarHit per ray, ray index = ring · columns + column. A
// dispatch covers the tile rows from tile_row_base on; dirs and hits are bound
// from rays dirs_base and hits_base (a sweep whose hits exceed one storage
// binding runs as several dispatches of whole tile rows).
// Known limit: lavapipe ends every loop of an invocation once its loops have made
// 65,535 iterations in all (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS); a tile list of
// tens of thousands of Gaussians could be cut short there without a flag (the loops
// here are per-lane divergent, so a lane's own count cannot tell; splat_blend,
// whose loops are uniform, counts and reports).
// Host module: engine/splat/lidar_gaussians_gpu.cpp; test: tests/splat/test_lidar_gaussians.cpp.
#include "shared/splat_lidar_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatLidarParams p; };
layout(std430, binding = 0) readonly buffer Ranges { uvec2 ranges[]; };
layout(std430, binding = 1) readonly buffer Keys { uvec2 keys[]; };
layout(std430, binding = 2) readonly buffer Values { uint values[]; };
#define LIDAR_GAUSSIAN_BINDING 3  // bindings 3-6: the Gaussian windows
#include "splat/lidar_gaussians.glsl"
layout(std430, binding = 7) readonly buffer Dirs { vec4 dirs[]; };  // sensor frame, ray order
layout(std430, binding = 8) writeonly buffer Hits { SplatLidarHit hits[]; };

float T = 1.0, wt = 0.0, wi = 0.0, median = 0.0;
uint count = 0u, flags = 0u;
bool stopped = false;

const float kEmpty = 1e30;  // an empty slot (ranges are at most 655 m)
float bt[SPLAT_LIDAR_K + 1], ba[SPLAT_LIDAR_K + 1], bi[SPLAT_LIDAR_K + 1];
uint bg[SPLAT_LIDAR_K + 1], bk[SPLAT_LIDAR_K + 1];

// Removes slot 0 (shifts the rest down, the last slot becomes empty).
void pop_front() {
  for (int q = 0; q < SPLAT_LIDAR_K; ++q) {
    bt[q] = bt[q + 1];
    ba[q] = ba[q + 1];
    bi[q] = bi[q + 1];
    bg[q] = bg[q + 1];
    bk[q] = bk[q + 1];
  }
  bt[SPLAT_LIDAR_K] = kEmpty;
}

void composite(float t, float a, float inten) {
  const float test_t = T * (1.0 - a);
  if (test_t < 1e-4) {
    stopped = true;
    flags |= SPLAT_LIDAR_FLAG_STOPPED;
    return;
  }
  const float w = a * T;
  wt += w * t;
  wi += w * inten;
  if (T > 0.5 && test_t <= 0.5) {
    median = t;
    flags |= SPLAT_LIDAR_FLAG_MEDIAN;
  }
  T = test_t;
  ++count;
}

void main() {
  const uint tid = ICUBE_THREAD_LINEAR();
  const uint tile = tid / SPLAT_LIDAR_TILE_RAYS + p.tile_row_base * p.tiles_x;  // this batch's tile rows
  if (tile >= p.tiles_x * p.tiles_y) return;
  const uint l = tid % SPLAT_LIDAR_TILE_RAYS;
  const uint ring = (tile / p.tiles_x) * SPLAT_LIDAR_TILE_ROWS + l / SPLAT_LIDAR_TILE_COLS;
  const uint col = (tile % p.tiles_x) * SPLAT_LIDAR_TILE_COLS + l % SPLAT_LIDAR_TILE_COLS;
  if (ring >= p.beams || col >= p.columns) return;
  const uint ray = ring * p.columns + col;
  const vec3 ds = dirs[ray - p.dirs_base].xyz;
  const vec3 d = normalize(vec3(p.s00 * ds.x + p.s01 * ds.y + p.s02 * ds.z, p.s10 * ds.x + p.s11 * ds.y + p.s12 * ds.z,
                                p.s20 * ds.x + p.s21 * ds.y + p.s22 * ds.z));
  const vec3 o = vec3(p.ox, p.oy, p.oz);

  // Pending contributors in slots 0..K, ascending by (t*, Gaussian index), empty slots t = kEmpty.
  // Every loop over slots has a constant trip count and is unrolled, so the slots are plain registers (no
  // indexed arrays: lavapipe lowers those to select chains, real GPUs to local memory).
  float t_last = -1.0;  // (t_last, g_last): the last composited contributor (t* >= min_range >= 0 > -1)
  uint g_last = 0u;
  const uvec2 range = ranges[tile];
  uint k0 = range.x;  // list entries before k0 are finished (composited or never contributing)
  bool more = true;
  for (uint pass = 0u; pass < SPLAT_LIDAR_MAX_PASSES && more && !stopped; ++pass) {
    for (int q = 0; q <= SPLAT_LIDAR_K; ++q) bt[q] = kEmpty;
    bool dropped = false;  // some contributor was left for a later pass; (dt, dg) the smallest such
    float dt = 0.0;
    uint dg = 0u, restart = range.y;
    for (uint k = k0; k < range.y; ++k) {
      const float bound = uintBitsToFloat(keys[k].x);
      while (bt[0] < bound && !stopped) {  // no later entry can come before it
        composite(bt[0], ba[0], bi[0]);
        t_last = bt[0];
        g_last = bg[0];
        pop_front();
      }
      if (stopped) break;
      if (dropped && bound > dt) {  // every later entry belongs to a later pass
        restart = min(restart, k);
        break;
      }
      const uint gi = values[k];
      const vec4 g0 = gaussian_vec4(gi, 0u);
      const vec4 g2 = gaussian_vec4(gi, 2u);
      const vec3 m = g0.xyz - o;
      const vec3 x = cross(m, d);
      if (dot(x, x) > g2.w * g2.w) continue;  // the ray line misses the cut sphere
      const vec4 g1 = gaussian_vec4(gi, 1u);
      const vec4 g3 = gaussian_vec4(gi, 3u);
      const vec3 mw = vec3(dot(g1.xyz, m), dot(g2.xyz, m), dot(g3.xyz, m));
      const vec3 dw = vec3(dot(g1.xyz, d), dot(g2.xyz, d), dot(g3.xyz, d));
      const float a = dot(dw, dw);
      const float t = dot(dw, mw) / a;
      const vec3 c = cross(mw, dw);
      const float q2 = dot(c, c) / a;
      const float alpha = min(0.99, g0.w * exp(-0.5 * q2));
      if (!(alpha >= 1.0 / 255.0) || t < p.min_range || t > p.max_range) continue;
      if (t < t_last || (t == t_last && gi <= g_last)) continue;  // composited in an earlier pass
      if (dropped && (t > dt || (t == dt && gi > dg))) {         // after a dropped one: a later pass
        restart = min(restart, k);
        continue;
      }
      // Into the last slot (always empty here), then one bubble pass down.
      bt[SPLAT_LIDAR_K] = t;
      ba[SPLAT_LIDAR_K] = alpha;
      bi[SPLAT_LIDAR_K] = g1.w;
      bg[SPLAT_LIDAR_K] = gi;
      bk[SPLAT_LIDAR_K] = k;
      for (int q = SPLAT_LIDAR_K; q > 0; --q) {
        if (bt[q] < bt[q - 1] || (bt[q] == bt[q - 1] && bg[q] < bg[q - 1])) {
          const float t0 = bt[q], a0 = ba[q], i0 = bi[q];
          const uint g0i = bg[q], k0i = bk[q];
          bt[q] = bt[q - 1];
          ba[q] = ba[q - 1];
          bi[q] = bi[q - 1];
          bg[q] = bg[q - 1];
          bk[q] = bk[q - 1];
          bt[q - 1] = t0;
          ba[q - 1] = a0;
          bi[q - 1] = i0;
          bg[q - 1] = g0i;
          bk[q - 1] = k0i;
        }
      }
      if (bt[SPLAT_LIDAR_K] < kEmpty) {  // K + 1 pending: the largest waits for a later pass
        dropped = true;
        dt = bt[SPLAT_LIDAR_K];
        dg = bg[SPLAT_LIDAR_K];
        restart = min(restart, bk[SPLAT_LIDAR_K]);
        bt[SPLAT_LIDAR_K] = kEmpty;
      }
    }
    while (bt[0] < kEmpty && !stopped) {
      composite(bt[0], ba[0], bi[0]);
      t_last = bt[0];
      g_last = bg[0];
      pop_front();
    }
    more = dropped;
    k0 = restart;
    if (more) flags |= SPLAT_LIDAR_FLAG_OVERFLOW;
  }
  if (more && !stopped) flags |= SPLAT_LIDAR_FLAG_TRUNCATED;  // pass limit: the farthest contributors are missing
  SplatLidarHit h;
  const float acc = 1.0 - T;
  h.alpha = acc;
  h.t_expected = acc > 0.0 ? wt / acc : 0.0;
  h.t_median = median;
  h.intensity = acc > 0.0 ? wi / acc : 0.0;
  h.count = count;
  h.flags = flags;
  h.pad0 = 0.0;
  h.pad1 = 0.0;
  hits[ray - p.hits_base] = h;
}
