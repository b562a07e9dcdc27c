#version 460
#extension GL_GOOGLE_include_directive : require
// splat_blend_rows: the previous blend kernel, kept for the side-by-side
// benchmark (bench/bench_splat.cpp, SplatGpuVariant::tile_blend = false); the
// same results as splat/blend.comp. Front-to-back alpha blending per pixel over the pixel's tile
// range of the sorted instance list (rules and thresholds in
// engine/splat/rasterizer_cpu.h: skip power > 0 and α < 1/255, α ≤ 0.99, stop
// before T·(1−α) < 1e-4, per pixel).
// One invocation blends P = SPLAT_BLEND_PIXELS (splat_params.h) consecutive
// pixels of one tile row in registers, so each Gaussian's record is loaded
// once for P pixels; S = 16/P segments per row, 16·S invocations per tile,
// numbered tile-major: invocation l covers row (l & 7) + 8·((l >> 3) / S),
// columns P·((l >> 3) % S) + [0, P), so 8 consecutive invocations (lavapipe's
// subgroup) cover a P × 8 block. P = 16 (whole tile rows) measured fastest
// on lavapipe (bench/README.md); 4 and 8 are valid too.
// Per invocation, a cheap inner loop skips the Gaussians that cannot reach
// α >= 1/255 on its P-pixel segment, reading only the first two vec4 of the
// blend record (SplatBlendRecord): along the row, power(px) is a parabola with
// maximum fmax = −½dy²(c' − b'²/a') at px* = mean_x + b'dy/a' and it exceeds
// log_cut = ln(0.9/(255·o)) only on px* ± √(2(fmax − log_cut)/a'); segments
// more than one pixel outside that interval are skipped. The 10 % margin in
// log_cut and the pixel cover rounding, so the per-pixel loop sees every
// Gaussian that can pass its tests and results equal the reference loop; the
// skip is a real loop (not a masked branch), which is what saves time on
// lavapipe. No shared memory or barriers (slow on lavapipe).
// Host module: engine/splat/rasterizer_gpu.cpp; tests: tests/splat/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

#define SPLAT_BLEND_SEGS (SPLAT_TILE / SPLAT_BLEND_PIXELS)  // segments per tile row
#define SPLAT_BLEND_PER_TILE (SPLAT_TILE * SPLAT_BLEND_SEGS)  // invocations per tile

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatBlendParams p; };
layout(std430, binding = 0) readonly buffer Ranges { uvec2 ranges[]; };
// Divergent (per-lane) loads go through texel buffers: on lavapipe a texel fetch is a
// gather, a storage-buffer load at a divergent address a per-lane loop. Records are
// fetched as R32G32B32A32_UINT and bit-cast (exact on every driver).
layout(binding = 1) uniform usamplerBuffer values;   // R32_UINT: sorted instance Gaussian ids
layout(binding = 2) uniform usamplerBuffer records;  // R32G32B32A32_UINT: 3 texels per SplatBlendRecord
layout(std430, binding = 3) writeonly buffer Rgba { vec4 rgba[]; };
layout(std430, binding = 4) writeonly buffer Depth { vec2 depth[]; };
layout(binding = 5) uniform usamplerBuffer sky_texels;  // R32_UINT: RGBA8 sky texels

vec3 sky_texel(int x, int y) { return unpackUnorm4x8(texelFetch(sky_texels, int(uint(y) * p.sky_w + uint(x))).x).xyz; }
vec4 record(uint t) { return uintBitsToFloat(texelFetch(records, int(t))); }

// Mirrors engine/splat/sky.cpp sky_ray_dir + sky_color operation by operation.
vec3 splat_sky(float px, float py) {
  if (p.sky_kind == SPLAT_SKY_BACKGROUND) return vec3(p.bg_r, p.bg_g, p.bg_b);
  const float x = p.m00 * px + p.m01 * py + p.m02;
  const float y = p.m10 * px + p.m11 * py + p.m12;
  const float z = p.m20 * px + p.m21 * py + p.m22;
  const float inv = 1.0 / sqrt(x * x + y * y + z * z);
  const vec3 d = vec3(x * inv, y * inv, z * inv);
  if (p.sky_kind == SPLAT_SKY_GRADIENT) {
    const vec3 hor = vec3(p.hor_r, p.hor_g, p.hor_b);
    if (d.z >= 0.0) return hor + (vec3(p.zen_r, p.zen_g, p.zen_b) - hor) * d.z;
    return hor + (vec3(p.gnd_r, p.gnd_g, p.gnd_b) - hor) * (-d.z);
  }
  const float kPi = 3.14159265358979;
  const float lon = atan(d.y, d.x);
  const float theta = atan(sqrt(d.x * d.x + d.y * d.y), d.z);
  const float sx = (0.5 - lon / (2.0 * kPi)) * float(p.sky_w) - 0.5;
  const float sy = (theta / kPi) * float(p.sky_h) - 0.5;
  const float xf = floor(sx), yf = floor(sy);
  const float ax = sx - xf, ay = sy - yf;
  const int W = int(p.sky_w), H = int(p.sky_h);
  const int xi = int(xf);
  const int x0 = xi < 0 ? xi + W : (xi >= W ? xi - W : xi), x1 = x0 + 1 == W ? 0 : x0 + 1;
  const int y0 = clamp(int(yf), 0, H - 1), y1 = clamp(int(yf) + 1, 0, H - 1);
  const vec3 top = sky_texel(x0, y0) * (1.0 - ax) + sky_texel(x1, y0) * ax;
  const vec3 bot = sky_texel(x0, y1) * (1.0 - ax) + sky_texel(x1, y1) * ax;
  return top * (1.0 - ay) + bot * ay;
}

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  const uint tile = t / SPLAT_BLEND_PER_TILE;
  if (tile >= p.grid_x * p.grid_y) return;
  const uint local = t % SPLAT_BLEND_PER_TILE;
  const uint u0 = (tile % p.grid_x) * SPLAT_TILE + ((local >> 3) % SPLAT_BLEND_SEGS) * SPLAT_BLEND_PIXELS;
  const uint v = (p.tile_y0 + tile / p.grid_x) * SPLAT_TILE + (local & 7u) + 8u * ((local >> 3) / SPLAT_BLEND_SEGS);
  if (u0 >= p.width || v >= p.height) return;
  const float py = float(v) + p.pixel_offset;
  const float px0 = float(u0) + p.pixel_offset;  // sample x of the segment's first pixel
  float T[SPLAT_BLEND_PIXELS], wz[SPLAT_BLEND_PIXELS], median[SPLAT_BLEND_PIXELS];
  vec3 C[SPLAT_BLEND_PIXELS];
  uint alive = 0u;  // bit j: pixel u0 + j is inside the image and not finished
  for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
    T[j] = 1.0;
    wz[j] = 0.0;
    median[j] = 0.0;
    C[j] = vec3(0.0);
    if (u0 + uint(j) < p.width) alive |= 1u << j;
  }
  const uvec2 range = ranges[tile];
  uint k = range.x;
  while (alive != 0u) {
    // Next Gaussian that can reach α >= 1/255 on this segment.
    uint gi = 0u;
    vec4 g0 = vec4(0.0), g1 = vec4(0.0);
    bool found = false;
    while (k < range.y) {
      gi = texelFetch(values, int(k)).x;
      g0 = record(3u * gi);
      g1 = record(3u * gi + 1u);
      ++k;
      const float dy = g0.y - py;
      const float fmax = -0.5 * dy * dy * (g1.x - g0.w * g0.w / g0.z);
      const float xc = g0.x + g0.w * dy / g0.z;
      const float h = sqrt(2.0 * (fmax - g1.y) / g0.z) + 1.0;
      const bool miss = fmax < g1.y || xc - h > px0 + float(SPLAT_BLEND_PIXELS - 1) || xc + h < px0;
      if (!miss) {  // NaN anywhere: not a miss (conservative)
        found = true;
        break;
      }
    }
    if (!found) break;
    const vec3 rgb = record(3u * gi + 2u).xyz;
    const float dy = g0.y - py;
    for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
      if ((alive & (1u << j)) == 0u) continue;
      const float dx = g0.x - (float(u0 + uint(j)) + p.pixel_offset);
      const float power = -0.5 * (g0.z * dx * dx + g1.x * dy * dy) - g0.w * dx * dy;
      if (power > 0.0) continue;
      const float alpha = min(0.99, g1.z * exp(power));
      if (alpha < 1.0 / 255.0) continue;
      const float test_t = T[j] * (1.0 - alpha);
      if (test_t < 1e-4) {
        alive &= ~(1u << j);
        continue;
      }
      const float w = alpha * T[j];
      C[j] += rgb * w;
      wz[j] += g1.w * w;
      if (T[j] > 0.5 && test_t <= 0.5) median[j] = g1.w;
      T[j] = test_t;
    }
  }
  for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
    const uint u = u0 + uint(j);
    if (u >= p.width) break;
    const uint pix = (v - p.tile_y0 * SPLAT_TILE) * p.width + u;
    rgba[pix] = vec4(C[j] + T[j] * splat_sky(float(u) + p.pixel_offset, py), 1.0 - T[j]);
    depth[pix] = vec2(T[j] < 1.0 ? wz[j] / (1.0 - T[j]) : 0.0, median[j]);
  }
}
