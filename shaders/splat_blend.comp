#version 460
#extension GL_GOOGLE_include_directive : require
// splat_blend: front-to-back alpha blending per pixel over the pixel's tile
// range of the sorted instance list (rules and thresholds in
// engine/splat/rasterizer_cpu.h: skip power > 0 and α < 1/255, α ≤ 0.99, stop
// before T·(1−α) < 1e-4, per pixel).
// One invocation blends SPLAT_BLEND_PIXELS (8) consecutive pixels of one tile
// row in registers, so each Gaussian's 48 bytes are loaded once for 8 pixels;
// 32 invocations per tile (16 rows × 2 halves), numbered tile-major, so a
// subgroup shares one tile's list. Per Gaussian and row, the largest value of
// the Gaussian along the row, o·exp(−½dy²(c' − b'²/a')), is tested first: when
// it is below 0.9/255 no pixel of the row can pass the 1/255 test and the
// Gaussian is skipped for the row (the 10 % margin covers rounding, so results
// equal the per-pixel loop). No shared memory or barriers (slow on lavapipe).
// Outputs per pixel (row-major): rgba = (C + T·bg, 1 − T), depth = (expected
// Σwz/(1 − T), median).
// Host module: engine/splat/rasterizer_gpu.cpp; test: tests/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

#define SPLAT_BLEND_PIXELS 8

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatBlendParams p; };
layout(std430, binding = 0) readonly buffer Ranges { uvec2 ranges[]; };
layout(std430, binding = 1) readonly buffer Values { uint values[]; };
layout(std430, binding = 2) readonly buffer Proj { vec4 proj[]; };
layout(std430, binding = 3) writeonly buffer Rgba { vec4 rgba[]; };
layout(std430, binding = 4) writeonly buffer Depth { vec2 depth[]; };

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  const uint tile = t >> 5;
  if (tile >= p.grid_x * p.grid_y) return;
  const uint local = t & 31u;
  const uint u0 = (tile % p.grid_x) * SPLAT_TILE + (local & 1u) * SPLAT_BLEND_PIXELS;
  const uint v = (tile / p.grid_x) * SPLAT_TILE + (local >> 1);
  if (u0 >= p.width || v >= p.height) return;
  const float py = float(v) + p.pixel_offset;
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
  for (uint k = range.x; k < range.y && alive != 0u; ++k) {
    const uint gi = values[k];
    const vec4 g0 = proj[3u * gi];
    const vec4 g1 = proj[3u * gi + 1u];
    const float dy = g0.y - py;
    if (g1.x > 0.0) {
      const float row_max = -0.5 * dy * dy * (g1.z - g1.y * g1.y / g1.x);
      if (g0.w * exp(row_max) < 0.9 / 255.0) continue;
    }
    const vec3 rgb = proj[3u * gi + 2u].xyz;
    for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
      if ((alive & (1u << j)) == 0u) continue;
      const float dx = g0.x - (float(u0 + uint(j)) + p.pixel_offset);
      const float power = -0.5 * (g1.x * dx * dx + g1.z * dy * dy) - g1.y * dx * dy;
      if (power > 0.0) continue;
      const float alpha = min(0.99, g0.w * exp(power));
      if (alpha < 1.0 / 255.0) continue;
      const float test_t = T[j] * (1.0 - alpha);
      if (test_t < 1e-4) {
        alive &= ~(1u << j);
        continue;
      }
      const float w = alpha * T[j];
      C[j] += rgb * w;
      wz[j] += g0.z * w;
      if (T[j] > 0.5 && test_t <= 0.5) median[j] = g0.z;
      T[j] = test_t;
    }
  }
  for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
    const uint u = u0 + uint(j);
    if (u >= p.width) break;
    const uint pix = v * p.width + u;
    rgba[pix] = vec4(C[j] + T[j] * vec3(p.bg_r, p.bg_g, p.bg_b), 1.0 - T[j]);
    depth[pix] = vec2(T[j] < 1.0 ? wz[j] / (1.0 - T[j]) : 0.0, median[j]);
  }
}
