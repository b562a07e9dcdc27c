#version 460
#extension GL_GOOGLE_include_directive : require
// conv2d: y[b, co, oy, ox] = bias[co] + sum_{ci, ky, kx} w[co, ci, ky, kx] *
// x[b, ci, oy * s - p + ky, ox * s - p + kx] (zero outside), dense NCHW float32,
// any kernel, stride and padding: PyTorch's Conv2d, for the GSM's image networks
// (conv encoder, Depth-Anything's patch embedding, neck and fusion, the sky's
// patch embedding, x-unet). Register tile without shared memory: each invocation
// holds NN_CONV_CO_TILE output channels x NN_CONV2D_XRUN consecutive output
// columns in vec4 accumulators; for every input channel and tap it reads the
// tap's two weight vec4s (uniform across the workgroup: packed [ci * kh * kw +
// tap][co padded to 8]) once for the whole run. The input is an R32_SFLOAT
// texel buffer (one gather per load on lavapipe). Tensors beyond one storage
// binding run as windows of batch elements, output and input channels
// (Conv2dParams); later input windows accumulate into y.
// Host module: kernels/nn/conv2d.{h,cpp}; CPU reference: nn::cpu::conv2d (kernels/nn/conv2d.h).
// Tests: tests/nn/test_conv2d.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_CONV2D_GROUP) in;
layout(push_constant) uniform Push { Conv2dParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT
layout(std430, binding = 1) readonly buffer Weights { vec4 w_packed[]; };
layout(std430, binding = 2) readonly buffer Bias { float bias[]; };
layout(std430, binding = 3) buffer Out { float y_out[]; };

void main() {
  const uint g = icube_group_linear();
  const uint rest = g / p.pixel_tiles;
  const uint tile = g % p.pixel_tiles, cob = rest % p.co_blocks, b = rest / p.co_blocks;
  if (b >= p.batch) return;
  const uint runs = (p.out_w + NN_CONV2D_XRUN - 1u) / NN_CONV2D_XRUN;
  const uint t_raw = tile * NN_CONV2D_GROUP + gl_LocalInvocationID.x;
  const bool in_image = t_raw < p.out_h * runs;
  const uint t = in_image ? t_raw : 0u;
  const int oy = int(t / runs), ox0 = int(t % runs) * NN_CONV2D_XRUN;
  const int H = int(p.in_h), W = int(p.in_w), S = int(p.stride), P = int(p.padding);
  const uint plane = p.in_h * p.in_w, taps = p.kernel_h * p.kernel_w;

  vec4 acc_lo[NN_CONV2D_XRUN], acc_hi[NN_CONV2D_XRUN];
  for (int v = 0; v < NN_CONV2D_XRUN; ++v) {
    acc_lo[v] = vec4(0.0);
    acc_hi[v] = vec4(0.0);
  }
  const uint co_vec = p.co_begin / 4u + cob * (NN_CONV_CO_TILE / 4);
  for (uint cl = 0u; cl < p.ci_count; ++cl) {
    const uint x_base = p.x_offset + b * p.x_batch_stride + cl * plane;
    const uint w_base = (p.ci_begin + cl - p.w_ci_base) * taps;
    for (uint ky = 0u; ky < p.kernel_h; ++ky) {
      const int iy = oy * S - P + int(ky);
      const bool row_valid = iy >= 0 && iy < H;
      const uint x_row = x_base + uint(clamp(iy, 0, H - 1) * W);
      for (uint kx = 0u; kx < p.kernel_w; ++kx) {
        const uint wi = (w_base + ky * p.kernel_w + kx) * p.co_vec4s + co_vec;
        const vec4 w_lo = w_packed[wi];
        const vec4 w_hi = w_packed[wi + 1u];
        for (int v = 0; v < NN_CONV2D_XRUN; ++v) {
          const int ix = (ox0 + v) * S - P + int(kx);
          const float xv = row_valid && ix >= 0 && ix < W ? texelFetch(x_tex, int(x_row + uint(ix))).x : 0.0;
          acc_lo[v] = fma(w_lo, vec4(xv), acc_lo[v]);
          acc_hi[v] = fma(w_hi, vec4(xv), acc_hi[v]);
        }
      }
    }
  }
  if (!in_image) return;
  const uint out_plane = p.out_h * p.out_w;
  for (int v = 0; v < NN_CONV2D_XRUN; ++v) {
    if (ox0 + v >= int(p.out_w)) break;
    const uint pix = uint(oy) * p.out_w + uint(ox0 + v);
    for (uint c = 0u; c < NN_CONV_CO_TILE; ++c) {
      const uint cl = cob * NN_CONV_CO_TILE + c;  // channel within the window
      if (cl >= p.co_count) break;
      const float a = c < 4u ? acc_lo[v][c] : acc_hi[v][c - 4u];
      const uint yi = p.y_offset + b * p.y_batch_stride + cl * out_plane + pix;
      if (p.accumulate != 0u) y_out[yi] += a;
      else y_out[yi] = a + (p.has_bias != 0u ? bias[p.co_begin + cl] : 0.0);
    }
  }
}
