#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// splat_blend: front-to-back alpha blending per pixel over the pixel's tile
// range of the sorted instance list (rules and thresholds in
// engine/splat/rasterizer_cpu.h: skip power > 0 and α < 1/255, α ≤ 0.99, stop
// before T·(1−α) < 1e-4, per pixel).
// One workgroup per tile (tile = linear workgroup id: the tile's range is
// uniform). One invocation blends P = SPLAT_BLEND_PIXELS (splat_params.h)
// consecutive pixels of one tile row in registers; S = 16/P segments per row,
// 16·S invocations per workgroup: invocation l covers row (l & 7) +
// 8·((l >> 3) / S), columns P·((l >> 3) % S) + [0, P), so 8 consecutive
// invocations (lavapipe's subgroup) cover a P × 8 block.
// The subgroup walks the tile's Gaussians in batches of one per live lane:
// each lane loads one instance's blend record (independent loads, so their
// cache misses overlap; a chain of one uniform load per Gaussian waits for
// each miss in turn) and tests whether its α-cut ellipse (q <= −2·log_cut,
// log_cut = ln(0.9/(255·o)), the 10 % margin) reaches the subgroup's pixel
// block grown by 1 px (the slab test of common/splat_tiles.glsl: the chord's
// extreme x over the block's rows); a ballot gives the batch's needed
// Gaussians, which all lanes then evaluate in depth order with the record
// shuffled from its lane (uniform). Skipped Gaussians cannot pass the
// per-pixel tests, so results equal the reference loop. Loops exit on
// subgroup votes (uniform), so on lavapipe they are real loops, not masked
// branches; the blend stops when no pixel of the subgroup is live. No shared
// memory or barriers (slow on lavapipe).
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
  const uint tile = icube_group_linear();  // uniform: one tile per workgroup
  if (tile >= p.grid_x * p.grid_y) return;
  const uint local = gl_LocalInvocationID.x;
  const uint u0 = (tile % p.grid_x) * SPLAT_TILE + ((local >> 3) % SPLAT_BLEND_SEGS) * SPLAT_BLEND_PIXELS;
  const uint v = (tile / p.grid_x) * SPLAT_TILE + (local & 7u) + 8u * ((local >> 3) / SPLAT_BLEND_SEGS);
  const float py = float(v) + p.pixel_offset;
  const float px0 = float(u0) + p.pixel_offset;  // sample x of the segment's first pixel
  // The subgroup's pixel block (sample coordinates), grown by 1 px: uniform.
  const float bx0 = subgroupMin(px0) - 1.0, bx1 = subgroupMax(px0) + float(SPLAT_BLEND_PIXELS - 1) + 1.0;
  const float by0 = subgroupMin(py) - 1.0, by1 = subgroupMax(py) + 1.0;
  const uint lanes = subgroupBallotBitCount(subgroupBallot(true));  // active lanes: 0 .. lanes-1
  const uint lane = gl_SubgroupInvocationID;
  float T[SPLAT_BLEND_PIXELS], wz[SPLAT_BLEND_PIXELS], median[SPLAT_BLEND_PIXELS];
  vec3 C[SPLAT_BLEND_PIXELS];
  uint alive = 0u;  // bit j: pixel u0 + j is inside the image and not finished
  for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
    T[j] = 1.0;
    wz[j] = 0.0;
    median[j] = 0.0;
    C[j] = vec3(0.0);
    if (u0 + uint(j) < p.width && v < p.height) alive |= 1u << j;
  }
  const uvec2 range = ranges[tile];
  for (uint base = range.x; base < range.y && subgroupAny(alive != 0u); base += lanes) {
    // This lane's instance of the batch: record and block test.
    const uint k = base + lane;
    vec4 b0 = vec4(0.0), b1 = vec4(0.0), b2 = vec4(0.0);
    bool need = false;
    if (k < range.y) {
      const uint gi = texelFetch(values, int(k)).x;
      b0 = record(3u * gi);
      b1 = record(3u * gi + 1u);
      b2 = record(3u * gi + 2u);
      const float mx = b0.x, my = b0.y, a = b0.z, b = b0.w, c = b1.x;
      const float R = -2.0 * b1.y;
      const float D = a * c - b * b;
      const float ex = sqrt(R * c / D), ey = sqrt(R * a / D);
      const float lo = max(by0 - my, -ey), hi = min(by1 - my, ey);
      const float dyr = -(b / c) * ex;
      const float yr = min(max(dyr, lo), hi), yl = min(max(-dyr, lo), hi);
      const float xr = mx + (sqrt(max(0.0, a * R - D * (yr * yr))) - b * yr) / a;
      const float xl = mx + (-sqrt(max(0.0, a * R - D * (yl * yl))) - b * yl) / a;
      need = !(lo > hi || xr < bx0 || xl > bx1);  // NaN anywhere: needed (conservative)
    }
    uint mask = subgroupBallot(need).x;  // batch entries in depth order (lanes <= 32 here)
    while (mask != 0u && subgroupAny(alive != 0u)) {
      const uint e = findLSB(mask);
      mask &= mask - 1u;
      const vec4 g0 = subgroupShuffle(b0, e), g1 = subgroupShuffle(b1, e);
      const vec3 rgb = subgroupShuffle(b2, e).xyz;
      const float dy = g0.y - py;
      for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
        const float dx = g0.x - (float(u0 + uint(j)) + p.pixel_offset);
        const float power = -0.5 * (g0.z * dx * dx + g1.x * dy * dy) - g0.w * dx * dy;
        const float alpha = min(0.99, g1.z * exp(power));
        const bool ok = (alive & (1u << j)) != 0u && power <= 0.0 && alpha >= 1.0 / 255.0;
        const float test_t = T[j] * (1.0 - alpha);
        const bool stop = ok && test_t < 1e-4;
        alive &= stop ? ~(1u << j) : ~0u;
        const bool use = ok && !stop;
        const float w = use ? alpha * T[j] : 0.0;
        C[j] += rgb * w;
        wz[j] += g1.w * w;
        median[j] = use && T[j] > 0.5 && test_t <= 0.5 ? g1.w : median[j];
        T[j] = use ? test_t : T[j];
      }
    }
  }
  if (v >= p.height) return;
  for (int j = 0; j < SPLAT_BLEND_PIXELS; ++j) {
    const uint u = u0 + uint(j);
    if (u >= p.width) break;
    const uint pix = v * p.width + u;
    rgba[pix] = vec4(C[j] + T[j] * splat_sky(float(u) + p.pixel_offset, py), 1.0 - T[j]);
    depth[pix] = vec2(T[j] < 1.0 ? wz[j] / (1.0 - T[j]) : 0.0, median[j]);
  }
}
