#version 460
#extension GL_GOOGLE_include_directive : require
// splat_slice_keys: one invocation per Gaussian of a window (n Gaussians) of a frame
// rendered in depth slices (engine/splat/depth_slices.h): its depth sort key exactly as
// splat/preprocess.comp computes it (the same splat_project of splat/project.glsl, without
// the colour), or SPLAT_SLICE_CULLED when preprocess would cull it, and its tile rect's area
// (the tile instances it can make at most; 0 when culled).
// Every binding starts at the window: rows gaussians[3li..3li+2] in, keys[li], tiles[li] out.
// Host module: engine/splat/depth_slices.cpp; test: tests/splat/test_depth_slices.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatPreprocessParams p; };
layout(binding = 0) uniform usamplerBuffer gaussians;  // R32G32B32A32_UINT: 3 texels per SplatGaussian
layout(std430, binding = 1) writeonly buffer Keys { uint keys[]; };
layout(std430, binding = 2) writeonly buffer Tiles { uint tiles[]; };

// The colour is not needed: degree 0 with zero coefficients.
const uint SPLAT_SH_DEGREE = 0u;
float splat_sh_coeff(uint o) { return 0.0; }
#include "splat/project.glsl"

void main() {
  const uint li = ICUBE_THREAD_LINEAR();
  if (li >= p.n) return;
  const vec4 g0 = uintBitsToFloat(texelFetch(gaussians, int(3u * li)));
  const vec4 g1 = uintBitsToFloat(texelFetch(gaussians, int(3u * li + 1u)));
  const vec4 g2 = uintBitsToFloat(texelFetch(gaussians, int(3u * li + 2u)));
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
  const bool vis = splat_project(d, g0.w, cov, o0, o1, o2, rect);
  const uint key = p.depth_key16 != 0u
                       ? uint(clamp(int(floatBitsToUint(o0.z) >> 12) - SPLAT_DEPTH_KEY16_OFFSET, 0, 65535))
                       : floatBitsToUint(o0.z);
  keys[li] = vis ? key : SPLAT_SLICE_CULLED;
  tiles[li] = vis ? (rect.z - rect.x) * (rect.w - rect.y) : 0u;
}
