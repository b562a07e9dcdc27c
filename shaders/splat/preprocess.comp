#version 460
#extension GL_GOOGLE_include_directive : require
// splat_preprocess: one invocation per Gaussian of a window [first, first + n):
// camera-relative position, EWA projection, conic, radius, tile rect, SH colour
// (splat/project.glsl; rules in engine/splat/rasterizer_cpu.h).
// Inputs: gaussians[3i..3i+2] = (pos - origin, opacity), (Σ00 Σ01 Σ02 Σ11),
// (Σ12 Σ22, 0, 0), i.e. SplatGaussian (48 B, read as three vec4); the SH
// window holds sh_stride floats (a multiple of 4) per Gaussian starting at
// Gaussian `first`, of which SPLAT_SH_DEGREE's bands are read as whole vec4
// texels (12 fetches for degree 3 instead of 48).
// Outputs (global index): proj[3i..3i+2] (SplatProjected), rects[i] (tile rect,
// zero when culled; the exact tile culling happens in
// splat/sorted_counts.comp), and the
// depth-sort input depth_keys[i] = float bits of view z (0 when culled; z > 0,
// so the bits order like the depths), or with p.depth_key16 their 16-bit
// log-linear code (shared/splat_params.h), depth_values[i] = i, and the blend
// record records[3i..3i+2] (SplatBlendRecord; unused when culled).
// Host module: engine/splat/rasterizer_gpu.cpp; test: tests/splat/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
// The scene's SH degree (0-3; a pipeline per degree): the SH row is read in whole texels and
// the unused bands' code is left out.
layout(constant_id = 1) const uint SPLAT_SH_DEGREE = 3;
layout(push_constant) uniform Push { SplatPreprocessParams p; };
// The per-Gaussian reads are strided (48 B, sh_stride floats): texel fetches (a gather on
// lavapipe, a per-lane loop as storage-buffer loads), bit-cast from uint (exact).
layout(binding = 0) uniform usamplerBuffer gaussians;  // R32G32B32A32_UINT: 3 texels per SplatGaussian
layout(binding = 1) uniform usamplerBuffer sh_coeffs;  // R32G32B32A32_UINT: the SH window, sh_stride / 4 texels per Gaussian

// The Gaussian's SH row (3·(degree + 1)² floats, rounded up to whole texels), fetched once.
#define SPLAT_SH_TEXELS ((3u * (SPLAT_SH_DEGREE + 1u) * (SPLAT_SH_DEGREE + 1u) + 3u) / 4u)
float sh_row[48];
float splat_sh_coeff(uint o) { return sh_row[o]; }
layout(std430, binding = 2) writeonly buffer Proj { vec4 proj[]; };
layout(std430, binding = 3) writeonly buffer Rects { uvec4 rects[]; };
layout(std430, binding = 4) writeonly buffer DepthKeys { uint depth_keys[]; };
layout(std430, binding = 5) writeonly buffer DepthValues { uint depth_values[]; };
layout(std430, binding = 6) writeonly buffer Records { vec4 records[]; };

#include "splat/project.glsl"

void main() {
  const uint li = ICUBE_THREAD_LINEAR();
  if (li >= p.n) return;
  const uint i = p.first + li;
  const vec4 g0 = uintBitsToFloat(texelFetch(gaussians, int(3u * i)));
  const vec4 g1 = uintBitsToFloat(texelFetch(gaussians, int(3u * i + 1u)));
  const vec4 g2 = uintBitsToFloat(texelFetch(gaussians, int(3u * i + 2u)));
  float cov[6];
  cov[0] = g1.x;
  cov[1] = g1.y;
  cov[2] = g1.z;
  cov[3] = g1.w;
  cov[4] = g2.x;
  cov[5] = g2.y;
  vec4 o0, o1, o2;
  uvec4 rect;
  const vec3 d = g0.xyz - vec3(p.cam_x, p.cam_y, p.cam_z);
  const uint sh_texel = li * (p.sh_stride / 4u);
  for (uint t = 0u; t < SPLAT_SH_TEXELS; ++t) {
    const vec4 v = uintBitsToFloat(texelFetch(sh_coeffs, int(sh_texel + t)));
    sh_row[4u * t] = v.x;
    sh_row[4u * t + 1u] = v.y;
    sh_row[4u * t + 2u] = v.z;
    sh_row[4u * t + 3u] = v.w;
  }
  const bool vis = splat_project(d, g0.w, cov, o0, o1, o2, rect);
  proj[3u * i] = o0;
  proj[3u * i + 1u] = o1;
  proj[3u * i + 2u] = o2;
  rects[i] = rect;
  const float log_cut = vis ? log(0.9 / (255.0 * o0.w)) : 0.0;
  depth_keys[i] = p.depth_key16 != 0u
                      ? uint(clamp(int(floatBitsToUint(o0.z) >> 12) - SPLAT_DEPTH_KEY16_OFFSET, 0, 65535))
                      : floatBitsToUint(o0.z);
  depth_values[i] = i;
  records[3u * i] = vec4(o0.xy, o1.xy);
  records[3u * i + 1u] = vec4(o1.z, log_cut, o0.w, o0.z);
  records[3u * i + 2u] = o2;
}
