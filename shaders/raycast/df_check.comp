#version 460
#extension GL_GOOGLE_include_directive : require
// raycast_df_check: a test kernel for the double-float primitives of
// common/df.glsl that the ray caster's float-only exact pass
// (raycast/exact_df.comp) is built on: out[i] = op(in[i].xy, in[i].zw) as
// (hi, lo, 0, 0), op = p.op (RAYCAST_DF_* in shared/raycast_df_params.h;
// df_two_sum / df_two_prod / df_split take the hi words only), or the ray
// caster's df chord (RAYCAST_DF_CHORD, raycast/chord_df.glsl). So the
// compiled code of this device (fusion, reassociation, division and sqrt
// accuracy) is what is tested. Host module: engine/render/raycast_gpu.{h,cpp}
// (df_check_gpu); test: tests/render/test_raycast_df.cpp.
#include "shared/raycast_df_params.h"
#include "raycast/chord_df.glsl"
#include "common/dispatch.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { RaycastDfCheckParams p; };
layout(std430, binding = 0) readonly buffer In { vec4 values[]; };
layout(std430, binding = 1) writeonly buffer Out { vec4 results[]; };
layout(std430, binding = 2) readonly buffer Camera { RaycastCameraDf cam; };  // RAYCAST_DF_CHORD

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.n) return;
  const vec2 a = values[i].xy, b = values[i].zw;
  vec2 r;
  if (p.op == RAYCAST_DF_TWO_SUM) r = df_two_sum(a.x, b.x);
  else if (p.op == RAYCAST_DF_TWO_PROD) r = df_two_prod(a.x, b.x);
  else if (p.op == RAYCAST_DF_ADD) r = df_add(a, b);
  else if (p.op == RAYCAST_DF_MUL) r = df_mul(a, b);
  else if (p.op == RAYCAST_DF_DIV) r = df_div(a, b);
  else if (p.op == RAYCAST_DF_SQRT) r = df_sqrt(a);
  else if (p.op == RAYCAST_DF_CHORD) {
    const uint px = floatBitsToUint(values[i].w);
    r = raycast_chord_df(cam, floatBitsToInt(values[i].xyz), uvec2(px & 0xffffu, px >> 16u),
                         ivec3(p.lo_x, p.lo_y, p.lo_z), ivec3(p.hi_x, p.hi_y, p.hi_z));
  }
  else r = df_split(a.x);
  results[i] = vec4(r, 0.0, 0.0);
}
