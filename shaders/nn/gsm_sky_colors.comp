#version 460
#extension GL_GOOGLE_include_directive : require
// gsm_sky_colors: the GSM's sky colour for each unit direction (InfiniCube's
// skybox_mlp_modulator under a batch element's sky token): the direction's
// embedding h = pos_w d + pos_b, LayerNorm over h (no affine, eps 1e-6, the
// biased variance), modulated n (1 + scale) + shift by the element's
// adaLN vectors (computed from its token on the host), then the output linear.
// One invocation per direction of the dispatch's window; h is recomputed in
// each of the three passes (mean, variance, output: 3 FMAs a unit) instead of
// held in an array. float32 throughout. Layouts in shared/nn_gsm_params.h.
// Host module: kernels/nn/gsm_sky_colors.{h,cpp}; CPU reference:
// nn::cpu::gsm_sky_colors. Tests: tests/nn/test_gsm_sky_colors.cpp.
#include "shared/nn_gsm_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_GSM_SKY_GROUP) in;
layout(push_constant) uniform Push { GsmSkyColorsParams p; };
layout(std430, binding = 0) readonly buffer Dirs { float dirs[]; };
layout(std430, binding = 1) readonly buffer Mlp { float mlp[]; };         // pos_w, pos_b, out_w, out_b
layout(std430, binding = 2) readonly buffer Modulation { float mod_[]; };  // [elements][2 hidden]: shift, scale
layout(std430, binding = 3) writeonly buffer Colors { float y[]; };

float embedding(uint k, vec3 d) {
  return mlp[3u * p.hidden + k] + mlp[3u * k] * d.x + mlp[3u * k + 1u] * d.y + mlp[3u * k + 2u] * d.z;
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.rows) return;
  const uint e = p.element_first + (p.first_row + i) / p.element_rows;
  const vec3 d = vec3(dirs[p.dir_offset + 3u * i], dirs[p.dir_offset + 3u * i + 1u], dirs[p.dir_offset + 3u * i + 2u]);
  const float inv_hidden = 1.0 / float(p.hidden);
  float sum = 0.0;
  for (uint k = 0u; k < p.hidden; ++k) sum += embedding(k, d);
  const float mean = sum * inv_hidden;
  float squares = 0.0;
  for (uint k = 0u; k < p.hidden; ++k) {
    const float c = embedding(k, d) - mean;
    squares = fma(c, c, squares);
  }
  const float inv_std = 1.0 / sqrt(squares * inv_hidden + 1e-6);
  const uint out_w = 4u * p.hidden, out_b = out_w + p.out_channels * p.hidden, m = 2u * p.hidden * e;
  float acc[NN_GSM_SKY_MAX_OUT];
  for (uint c = 0u; c < p.out_channels; ++c) acc[c] = 0.0;
  for (uint k = 0u; k < p.hidden; ++k) {
    const float n = (embedding(k, d) - mean) * inv_std;
    const float v = fma(n, 1.0 + mod_[m + p.hidden + k], mod_[m + k]);
    for (uint c = 0u; c < p.out_channels; ++c) acc[c] = fma(mlp[out_w + c * p.hidden + k], v, acc[c]);
  }
  for (uint c = 0u; c < p.out_channels; ++c) y[p.out_offset + p.out_channels * i + c] = acc[c] + mlp[out_b + c];
}
