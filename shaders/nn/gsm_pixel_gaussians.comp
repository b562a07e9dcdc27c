#version 460
#extension GL_GOOGLE_include_directive : require
// gsm_pixel_gaussians: the GSM pixel branch's Gaussian decoding (InfiniCube
// Pure2DUNet; gsm_small README step 6), dense over every pixel of one view:
//   ray   pixel (col, row) at integer coordinates: u = (col - cx) / fx,
//         v = (row - cy) / fy; d = float(P [u, v, 1, 1]^T)[:3] - t (the sum
//         carried as a float pair and rounded once, as the reference's double
//         sum rounded to float; t = the pose's translation), dir = d / |d|
//   depth sigmoid(raw0) (zfar - znear) + znear, or 1 / sigmoid(raw0)
//         (NN_GSMPIX_FLAG_INVERSE_DEPTH); distance = depth / <pose z axis, dir>
//   mean  t + distance dir; scale min(exp(raw - 2.3), max_scale); rotation
//         raw / max(|raw|, 1e-12) (scaled by its largest component first, so
//         no overflow); opacity sigmoid(raw8 - 1); colour raw9.. as is
//   mask  fg - fg * grid_fg (NN_GSMPIX_FLAG_MIDGROUND) or fg
// One invocation per pixel, looping over the pixel's gs_per_pixel Gaussians;
// consecutive invocations read consecutive pixels of each raw channel.
// Host module: kernels/nn/gsm_pixel_gaussians.{h,cpp}; CPU reference:
// nn::cpu::gsm_pixel_gaussians. Tests: tests/nn/test_gsm_pixel_gaussians.cpp.
#include "shared/nn_gsm_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_GSMPIX_GROUP) in;
layout(push_constant) uniform Push { GsmPixelGaussiansParams p; };
layout(std430, binding = 0) readonly buffer Raw { float raw_in[]; };
layout(std430, binding = 1) readonly buffer Fg { float fg_in[]; };
layout(std430, binding = 2) readonly buffer Grid { float grid_in[]; };
layout(std430, binding = 3) readonly buffer Cameras { float cam[]; };
layout(std430, binding = 4) writeonly buffer Out { float out_g[]; };
layout(std430, binding = 5) writeonly buffer Mask { float mask_out[]; };

// a / b, corrected once by its residual (GLSL's division may be off by 2.5 ulp; the reference's is rounded).
float divided(float a, float b) {
  precise float q = a / b;
  precise float r = fma(-q, b, a);
  precise float c = q + r / b;
  return c;
}

// s = a + b rounded, e = the rounding error (Knuth's two-sum; exact).
float two_sum(float a, float b, out float e) {
  precise float s = a + b;
  precise float bb = s - a;
  precise float err = (a - (s - bb)) + (b - bb);
  e = err;
  return s;
}

// Row `base` of the pose applied to (u, v, 1, 1): products and sums carried with their errors, rounded once.
float pose_row(uint base, float u, float v) {
  const float a = cam[base], b = cam[base + 1u], c = cam[base + 2u], t = cam[base + 3u];
  precise float pa = a * u;
  precise float ea = fma(a, u, -pa);
  precise float pb = b * v;
  precise float eb = fma(b, v, -pb);
  float e1, e2, e3;
  float s = two_sum(pa, pb, e1);
  s = two_sum(s, c, e2);
  s = two_sum(s, t, e3);
  precise float lo = ((ea + eb) + e1) + (e2 + e3);
  precise float r = s + lo;
  return r;
}

float sigmoid(float x) { return 1.0 / (1.0 + exp(-x)); }

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.pixels) return;
  const float fg = fg_in[p.fg_offset + i], grid = grid_in[p.grid_offset + i];
  mask_out[p.mask_offset + i] = (p.flags & NN_GSMPIX_FLAG_MIDGROUND) != 0u ? fg - fg * grid : fg;

  const uint cb = p.camera;
  const float u = divided(float(i % p.width) - cam[cb + 18u], cam[cb + 16u]);
  const float v = divided(float(i / p.width) - cam[cb + 19u], cam[cb + 17u]);
  vec3 t, d;
  for (uint k = 0u; k < 3u; ++k) {
    t[k] = cam[cb + 4u * k + 3u];
    precise float dk = pose_row(cb + 4u * k, u, v) - t[k];
    d[k] = dk;
  }
  const vec3 dir = d / length(d);
  const float cosine = cam[cb + 2u] * dir.x + cam[cb + 6u] * dir.y + cam[cb + 10u] * dir.z;

  const uint G = p.gs_per_pixel, D = p.gs_dim, R = D + 2u;
  for (uint s = 0u; s < G; ++s) {
    const uint src = p.params_offset + s * D * p.pixels + i;
    const uint o = p.out_offset + (i * G + s) * R;
    const float w = sigmoid(raw_in[src]);
    const float depth = (p.flags & NN_GSMPIX_FLAG_INVERSE_DEPTH) != 0u ? 1.0 / w : fma(w, p.depth_range, p.znear);
    const float distance = depth / cosine;
    for (uint k = 0u; k < 3u; ++k) {
      out_g[o + k] = fma(distance, dir[k], t[k]);
      out_g[o + 3u + k] = min(exp(raw_in[src + (1u + k) * p.pixels] - 2.3), p.max_scale);
    }
    vec4 q;
    for (uint k = 0u; k < 4u; ++k) q[k] = raw_in[src + (4u + k) * p.pixels];
    const float largest = max(max(abs(q.x), abs(q.y)), max(abs(q.z), abs(q.w)));
    vec4 rotation = vec4(0.0);
    if (largest > 0.0) {
      const vec4 qs = q / largest;
      const float n = length(qs);
      // |q| = n * largest; below 1e-12 the official divides by 1e-12 instead.
      rotation = n >= 1e-12 / largest ? qs / n : q * 1e12;
    }
    for (uint k = 0u; k < 4u; ++k) out_g[o + 6u + k] = rotation[k];
    out_g[o + 10u] = sigmoid(raw_in[src + 8u * p.pixels] - 1.0);
    for (uint k = 9u; k < D; ++k) out_g[o + 2u + k] = raw_in[src + k * p.pixels];
  }
}
