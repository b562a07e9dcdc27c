#version 460
#extension GL_GOOGLE_include_directive : require
// interpolate: PyTorch's F.interpolate of [planes = batch * channels, H, W]
// float32 maps to [planes, out_h, out_w] by output size (the GSM resizes its
// images, Depth-Anything's position grid and features): nearest, bilinear and
// bicubic (a = -0.75, border-clamped taps), with or without align_corners
// (InterpolateParams.mode / align_corners). One thread per output element.
// Source positions are computed exactly in integers (floor and remainder of a
// ratio), so tap indices never depend on float rounding; only the fraction
// and the blend are float32. Tensors beyond one storage binding run as windows
// of whole planes (x_offset / y_offset).
// Host module: kernels/nn/interpolate.{h,cpp}; CPU reference: nn::cpu::resize_*
// (kernels/nn/interpolate.h). Tests: tests/nn/test_interpolate.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_INTERP_GROUP) in;
layout(push_constant) uniform Push { InterpolateParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) writeonly buffer Out { float y_out[]; };

// The source position of output index `dst` on an axis of `in_size` -> `out_size` samples as
// base + t, base = its floor, t in [0, 1): num / den with align_corners dst (in - 1) / (out - 1)
// (0 when out = 1), else ((2 dst + 1) in - out) / (2 out), clamped at 0 when `clamp_low` (bilinear).
// The host keeps 2 out in below 2^31.
void source_position(uint dst, uint in_size, uint out_size, bool clamp_low, out int base, out float t) {
  int num, den;
  if (p.align_corners != 0u) {
    num = int(dst * (in_size - 1u));
    den = int(max(out_size, 2u) - 1u);
  } else {
    num = int((2u * dst + 1u) * in_size) - int(out_size);
    den = int(2u * out_size);
    if (clamp_low) num = max(num, 0);
  }
  base = num >= 0 ? num / den : -((den - 1 - num) / den);
  t = float(num - base * den) / float(den);
}

// Keys' cubic convolution weights with a = -0.75 for the taps base - 1 .. base + 2 at fraction t,
// in factored forms of PyTorch's polynomials (the same values, without their cancellation):
// |s| <= 1: ((a + 2) s - (a + 3)) s^2 + 1 = (s - 1) ((a + 2) s^2 - s - 1);
// 1 < |s| < 2: ((a s - 5a) s + 8a) s - 4a = a (s - 1) (s - 2)^2.
vec4 cubic_weights(float t) {
  const float a = -0.75, u = 1.0 - t;
  return vec4(a * t * u * u,                           // s = 1 + t
              (t - 1.0) * ((a + 2.0) * t * t - t - 1.0),  // s = t
              (u - 1.0) * ((a + 2.0) * u * u - u - 1.0),  // s = 1 - t
              a * u * t * t);                          // s = 2 - t
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  const uint OH = p.out_h, OW = p.out_w, H = p.in_h, W = p.in_w;
  if (i >= p.planes * OH * OW) return;
  const uint ox = i % OW, oy = (i / OW) % OH, pl = i / (OW * OH);
  const uint plane = p.x_offset + pl * H * W;
  float v;
  if (p.mode == NN_INTERP_NEAREST) {
    const uint iy = min(oy * H / OH, H - 1u), ix = min(ox * W / OW, W - 1u);
    v = x_in[plane + iy * W + ix];
  } else if (p.mode == NN_INTERP_BILINEAR) {
    int by, bx;
    float ly, lx;
    source_position(oy, H, OH, true, by, ly);
    source_position(ox, W, OW, true, bx, lx);
    const uint y0 = min(uint(by), H - 1u), x0 = min(uint(bx), W - 1u);
    const uint y1 = min(y0 + 1u, H - 1u), x1 = min(x0 + 1u, W - 1u);
    const float top = (1.0 - lx) * x_in[plane + y0 * W + x0] + lx * x_in[plane + y0 * W + x1];
    const float bottom = (1.0 - lx) * x_in[plane + y1 * W + x0] + lx * x_in[plane + y1 * W + x1];
    v = (1.0 - ly) * top + ly * bottom;
  } else {
    int by, bx;
    float ty, tx;
    source_position(oy, H, OH, false, by, ty);
    source_position(ox, W, OW, false, bx, tx);
    const vec4 wy = cubic_weights(ty), wx = cubic_weights(tx);
    uint cols[4];
    for (int k = 0; k < 4; ++k) cols[k] = uint(clamp(bx - 1 + k, 0, int(W) - 1));
    v = 0.0;
    for (int r = 0; r < 4; ++r) {
      const uint row = plane + uint(clamp(by - 1 + r, 0, int(H) - 1)) * W;
      float acc = 0.0;
      for (int k = 0; k < 4; ++k) acc = fma(wx[k], x_in[row + cols[k]], acc);
      v = fma(wy[r], acc, v);
    }
  }
  y_out[p.y_offset + i] = v;
}
