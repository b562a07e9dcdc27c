#version 460
#extension GL_GOOGLE_include_directive : require
// appearance/shadow_rays: one shadow ray per pixel of a camera cast, in the
// ray caster's ray-list layout (2 vec4 per ray: origin relative to the camera's
// reference voxel corner in voxel units, unit world direction), for a second
// ray-cast dispatch towards the sun. A pixel with a surface hit starts at its
// hit point (camera offset + t_sem d / voxel size) moved 0.02 voxel out of the
// entry face; a pixel without one (sky) or whose face turns away from the sun
// (its sun term is 0 whatever the ray finds) gets a ray that starts above any
// world (z = 4e6 voxels) and leaves the bounds at once.
// Host module: engine/render/appearance/appearance_gpu.{h,cpp}; CPU reference:
// appearance_cpu.cpp (the same origins in double). Tests: tests/appearance/.
#include "shared/appearance_params.h"
#include "shared/raycast_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = 64) in;
layout(binding = 0) uniform usamplerBuffer hit_texels;  // RaycastHit records as 3 RGBA32UI texels each
layout(std430, binding = 1) readonly buffer Params { AppearanceParams P; };
layout(std430, binding = 2) writeonly buffer Rays { vec4 rays[]; };  // from pixel win.first
layout(push_constant) uniform Push { AppearanceWindow win; };

#include "shared/appearance_shading.h"

void main() {
  const uint i = win.first + ICUBE_THREAD_LINEAR();
  if (i >= win.end) return;
  const uvec2 px = uvec2(i % P.width, i / P.width);
  const float u = float(px.x) + P.pixel_offset, v = float(px.y) + P.pixel_offset;
  const vec3 d = normalize(vec3(P.m00 * u + P.m01 * v + P.m02, P.m10 * u + P.m11 * v + P.m12,
                                P.m20 * u + P.m21 * v + P.m22));
  const uvec4 h0 = texelFetch(hit_texels, int(3u * i)), h1 = texelFetch(hit_texels, int(3u * i + 1u));
  const uint flags = texelFetch(hit_texels, int(3u * i + 2u)).y;
  const vec3 sun = vec3(P.sun_x, P.sun_y, P.sun_z);
  vec3 o = vec3(P.off_x, P.off_y, 4.0e6);
  const ivec3 nf = shade_face_normal(int(h1.w), d);
  if ((flags & RAYCAST_FLAG_SEM) != 0u && dot(vec3(nf), sun) > 0.0)
    o = vec3(P.off_x, P.off_y, P.off_z) + d * (uintBitsToFloat(h0.x) / P.voxel_size) + vec3(nf) * 0.02;
  rays[2u * (i - win.first)] = vec4(o, 0.0);
  rays[2u * (i - win.first) + 1u] = vec4(sun, 0.0);
}
