#version 460
#extension GL_GOOGLE_include_directive : require
// conv_transpose2d: PyTorch's ConvTranspose2d on dense NCHW float32, gather
// form: y[b, o, oy, ox] = bias[o] + sum_{ci, ky, kx} w[ci, o, ky, kx] *
// x[b, ci, iy, ix] over the taps with oy + p - ky = iy s and ox + p - kx = ix s
// (iy, ix inside the input). The taps reaching an output pixel depend only on
// its phase (oy + p) mod s, (ox + p) mod s: ky = phase_y + m s (m >= 0, ky <
// kh), iy = (oy + p) / s - m, and the same along x. Each invocation holds
// NN_CONVT2D_CO_TILE output channels x NN_CONVT2D_XRUN output columns of one
// row and one column phase (columns s apart), so for every input channel and
// tap it reads the tap's two weight vec4s (packed [ci * kh * kw + tap][co
// padded to 8]) once for the whole run and NN_CONVT2D_XRUN consecutive input
// columns (an R32_SFLOAT texel buffer: one gather per load on lavapipe).
// Windows of batch elements, output and input channels as conv2d's
// (ConvTranspose2dParams); later input windows accumulate into y.
// Host module: kernels/nn/conv_transpose2d.{h,cpp}; CPU reference:
// nn::cpu::conv_transpose2d. Tests: tests/nn/test_conv_transpose2d.cpp.
#include "shared/nn_gsm_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_CONVT2D_GROUP) in;
layout(push_constant) uniform Push { ConvTranspose2dParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT
layout(std430, binding = 1) readonly buffer Weights { vec4 w_packed[]; };
layout(std430, binding = 2) readonly buffer Bias { float bias[]; };
layout(std430, binding = 3) buffer Out { float y_out[]; };

void main() {
  const uint g = icube_group_linear();
  const uint rest = g / p.pixel_tiles;
  const uint tile = g % p.pixel_tiles, cob = rest % p.co_blocks, b = rest / p.co_blocks;
  if (b >= p.batch) return;
  const uint S = p.stride;
  const uint per_row = S * p.runs;
  const uint t_raw = tile * NN_CONVT2D_GROUP + gl_LocalInvocationID.x;
  const bool in_image = t_raw < p.out_h * per_row;
  const uint t = in_image ? t_raw : 0u;
  const uint oy = t / per_row, phase_x = (t % per_row) / p.runs, run = t % p.runs;
  // The first output column of the phase: the smallest ox >= 0 with (ox + p) mod s = phase_x.
  const uint first_x = (phase_x + S - p.padding % S) % S;
  const uint j0 = run * NN_CONVT2D_XRUN;                      // columns first_x + (j0 + v) s
  const int ix_base = int((first_x + p.padding - phase_x) / S + j0);  // input column of tap phase_x, v = 0
  const uint ty = oy + p.padding, phase_y = ty % S;
  const int H = int(p.in_h), W = int(p.in_w);
  const uint plane = p.in_h * p.in_w, taps = p.kernel_h * p.kernel_w;

  vec4 acc_lo[NN_CONVT2D_XRUN], acc_hi[NN_CONVT2D_XRUN];
  for (int v = 0; v < NN_CONVT2D_XRUN; ++v) {
    acc_lo[v] = vec4(0.0);
    acc_hi[v] = vec4(0.0);
  }
  const uint co_vec = p.co_begin / 4u + cob * (NN_CONVT2D_CO_TILE / 4);
  for (uint cl = 0u; cl < p.ci_count; ++cl) {
    const uint x_base = p.x_offset + b * p.x_batch_stride + cl * plane;
    const uint w_base = p.w_offset + cl * taps * p.co_vec4s + co_vec;
    for (uint ky = phase_y; ky < p.kernel_h; ky += S) {
      const int iy = int(ty / S) - int((ky - phase_y) / S);
      if (iy < 0 || iy >= H) continue;
      const uint x_row = x_base + uint(iy * W);
      for (uint kx = phase_x; kx < p.kernel_w; kx += S) {
        const uint wi = w_base + (ky * p.kernel_w + kx) * p.co_vec4s;
        const vec4 w_lo = w_packed[wi];
        const vec4 w_hi = w_packed[wi + 1u];
        const int ix0 = ix_base - int((kx - phase_x) / S);
        for (int v = 0; v < NN_CONVT2D_XRUN; ++v) {
          const int ix = ix0 + v;
          const float xv = ix >= 0 && ix < W ? texelFetch(x_tex, int(x_row + uint(ix))).x : 0.0;
          acc_lo[v] = fma(w_lo, vec4(xv), acc_lo[v]);
          acc_hi[v] = fma(w_hi, vec4(xv), acc_hi[v]);
        }
      }
    }
  }
  if (!in_image) return;
  const uint out_plane = p.out_h * p.out_w;
  for (int v = 0; v < NN_CONVT2D_XRUN; ++v) {
    const uint ox = first_x + (j0 + uint(v)) * S;
    if (ox >= p.out_w) break;
    const uint pix = oy * p.out_w + ox;
    for (uint c = 0u; c < NN_CONVT2D_CO_TILE; ++c) {
      const uint cl = cob * NN_CONVT2D_CO_TILE + c;  // channel within the window
      if (cl >= p.co_count) break;
      const float a = c < 4u ? acc_lo[v][c] : acc_hi[v][c - 4u];
      const uint yi = p.y_offset + b * p.y_batch_stride + cl * out_plane + pix;
      if (p.accumulate != 0u) y_out[yi] += a;
      else y_out[yi] = a + (p.has_bias != 0u ? bias[p.co_begin + cl] : 0.0);
    }
  }
}
