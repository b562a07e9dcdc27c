#version 460
#extension GL_GOOGLE_include_directive : require
// gsm_voxel_gaussians: the GSM voxel heads' raw values decoded into Gaussians
// (gs_free_space "hard"): per voxel r and sub-Gaussian s, from the gs_dim raw
// values v = raw[s * gs_dim + k][r]: mean = voxel min corner + sigmoid(v0..2) *
// voxel size, scale = min(exp(v3..5) * scale_unit, max_scaling) (no clamp when
// max_scaling <= 0), rotation = v6..9 / max(|v6..9|, 1e-12), opacity =
// sigmoid(v10), colour = v11.. as they are. One invocation per Gaussian of the
// dispatch's window (voxels r0.., subs s0..; the host windows tensors past one
// storage binding); the outputs are row-major per Gaussian from Gaussian
// first_gaussian on (the second head appends after the first). Layouts in
// shared/nn_gsm_params.h.
// Host module: kernels/nn/gsm_voxel_gaussians.{h,cpp}; CPU reference:
// nn::cpu::gsm_voxel_gaussians. Tests: tests/nn/test_gsm_voxel_gaussians.cpp.
#include "shared/nn_gsm_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_GSM_GAUSSIANS_GROUP) in;
layout(push_constant) uniform Push { GsmVoxelGaussiansParams p; };
layout(std430, binding = 0) readonly buffer Raw { float raw[]; };
layout(std430, binding = 1) readonly buffer Coords { int ijk[]; };
layout(std430, binding = 2) writeonly buffer Means { float means[]; };
layout(std430, binding = 3) writeonly buffer Scales { float scales[]; };
layout(std430, binding = 4) writeonly buffer Rotations { float rotations[]; };
layout(std430, binding = 5) writeonly buffer Opacities { float opacities[]; };
layout(std430, binding = 6) writeonly buffer Colors { float colors[]; };

// Voxel r and sub s of the window.
float raw_value(uint r, uint s, uint k) { return raw[p.raw_offset + (s * p.gs_dim + k) * p.row_stride + r]; }

float sigmoid(float v) { return 1.0 / (1.0 + exp(-v)); }

void main() {
  const uint id = ICUBE_THREAD_LINEAR();
  if (id >= p.rows * p.subs) return;
  const uint r = id / p.subs, s = id % p.subs;
  const uint g = r * p.per_voxel + s;  // from the window's first Gaussian
  const vec3 size = vec3(p.voxel_size_x, p.voxel_size_y, p.voxel_size_z);
  const vec3 corner = vec3(float(ijk[p.ijk_offset + 3u * r]), float(ijk[p.ijk_offset + 3u * r + 1u]), float(ijk[p.ijk_offset + 3u * r + 2u])) * size +
                      vec3(p.corner_x, p.corner_y, p.corner_z);
  for (uint a = 0u; a < 3u; ++a) {
    means[p.means_offset + 3u * g + a] = fma(sigmoid(raw_value(r, s, a)), size[a], corner[a]);
    float scale = exp(raw_value(r, s, 3u + a)) * p.scale_unit;
    if (p.max_scaling > 0.0) scale = min(scale, p.max_scaling);
    scales[p.scales_offset + 3u * g + a] = scale;
  }
  const vec4 q = vec4(raw_value(r, s, 6u), raw_value(r, s, 7u), raw_value(r, s, 8u), raw_value(r, s, 9u));
  const vec4 unit = q / max(length(q), 1e-12);
  for (uint a = 0u; a < 4u; ++a) rotations[p.rotations_offset + 4u * g + a] = unit[a];
  opacities[p.opacities_offset + g] = sigmoid(raw_value(r, s, 10u));
  const uint color_dim = p.gs_dim - 11u;
  for (uint a = 0u; a < color_dim; ++a) colors[p.colors_offset + color_dim * g + a] = raw_value(r, s, 11u + a);
}
