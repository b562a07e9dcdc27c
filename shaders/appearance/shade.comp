#version 460
#extension GL_GOOGLE_include_directive : require
// appearance/shade: the procedural appearance of one camera frame from the
// ray caster's hits (shared/appearance_shading.h has the model): per pixel
// the hit voxel's material with world-fixed detail, lit by the sun (visibility
// from the shadow ray's hit when APPEARANCE_FLAG_SHADOWS), the sky's ambient
// light times ambient occlusion from occupancy probes around the hit face
// (APPEARANCE_FLAG_AO; texel lookups in the same world), street lamps and
// headlights (`lights`), specular sky reflection on wet ground, glass and
// paint, then fog and the tone curve; a pixel without a hit shows the sky.
// Output per pixel: RGBA8 (alpha 255 = surface, 0 = sky) and
// class << 16 | instance of the hit (0 for sky).
// Positions are relative to the camera's reference voxel corner (metres or
// voxels), texture keys are absolute ijk: exact 100 km from the origin.
// Structure, for CPU SIMD (lavapipe): the parameters are copied into a
// private `P` at the top while every lane is active (scalar loads there;
// inside branches they would be lane-by-lane loops), the lights are texel
// fetches (gathers), and surface and sky are computed for every pixel and
// selected at the end (a divergent branch would run both sides anyway).
// Host module: engine/render/appearance/appearance_gpu.{h,cpp}; CPU reference:
// appearance_cpu.cpp. Tests: tests/appearance/.
#include "shared/appearance_params.h"
#include "shared/raycast_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = 64) in;
// RaycastHit records (48 bytes) read as 3 RGBA32UI texels each: gathers instead of lane-by-lane loads.
layout(binding = 0) uniform usamplerBuffer hit_texels;
layout(binding = 1) uniform usamplerBuffer shadow_hit_texels;
layout(std430, binding = 2) readonly buffer Params { AppearanceParams params_in; };
layout(binding = 3) uniform samplerBuffer light_texels;  // AppearanceLight records as 3 RGBA32F texels each
layout(binding = 4) uniform usamplerBuffer world_table_texels;
layout(binding = 5) uniform usamplerBuffer world_brick_texels;
layout(std430, binding = 6) writeonly buffer Rgba { uint rgba[]; };      // from pixel win.first
layout(std430, binding = 7) writeonly buffer Labels { uint labels[]; };  // from pixel win.first
layout(push_constant) uniform Push { AppearanceWindow win; };

AppearanceParams P;

#include "world/lookup_texel.glsl"
#include "shared/appearance_shading.h"

void main() {
  P = params_in;
  const uint gi = win.first + ICUBE_THREAD_LINEAR();
  const bool live = gi < win.end;
  const uint i = live ? gi : 0u;
  const uvec2 px = uvec2(i % P.width, i / P.width);
  const float u = float(px.x) + P.pixel_offset, v = float(px.y) + P.pixel_offset;
  const vec3 d = normalize(vec3(P.m00 * u + P.m01 * v + P.m02, P.m10 * u + P.m11 * v + P.m12,
                                P.m20 * u + P.m21 * v + P.m22));
  const uvec4 h0 = texelFetch(hit_texels, int(3u * i)), h1 = texelFetch(hit_texels, int(3u * i + 1u));
  const uint flags = texelFetch(hit_texels, int(3u * i + 2u)).y;
  const float t_sem = uintBitsToFloat(h0.x);  // RaycastHit: t_sem, t_depth, sem_class, sem_instance | ijk, normal | steps, flags
  const uint sem_class = h0.z, sem_instance = h0.w;
  const bool surface = (flags & RAYCAST_FLAG_SEM) != 0u;

  const ivec3 ijk = ivec3(h1.xyz);
  const ivec3 nf = shade_face_normal(int(h1.w), d);
  const vec3 nrm = vec3(nf);
  const vec3 cam = vec3(P.off_x, P.off_y, P.off_z);
  const vec3 hit_vox = cam + d * (t_sem / P.voxel_size);  // voxel units, ref corner
  const vec3 local = clamp(hit_vox - vec3(ijk - ivec3(P.ref_x, P.ref_y, P.ref_z)), vec3(0.0), vec3(1.0));
  const vec3 pos = hit_vox * P.voxel_size;  // metres, ref corner

  vec3 lit = vec3(0.0);
  for (uint l = 0u; l < P.light_count; ++l) {
    const vec4 a = texelFetch(light_texels, int(3u * l)), b = texelFetch(light_texels, int(3u * l + 1u)),
               c = texelFetch(light_texels, int(3u * l + 2u));
    lit += shade_light(a.xyz, a.w, b.xyz, b.w, c.xyz, floatBitsToUint(c.w), pos, nrm);
  }
  float sun_vis = 1.0;
  if ((P.flags & APPEARANCE_FLAG_SHADOWS) != 0u) sun_vis = (texelFetch(shadow_hit_texels, int(3u * i + 2u)).y & RAYCAST_FLAG_SEM) != 0u ? 0.0 : 1.0;
  float occluded = 0.0;
  if ((P.flags & APPEARANCE_FLAG_AO) != 0u) {
    for (int k = 0; k < kShadeAoProbes; ++k)
      if (world_occupied_texel(shade_ao_probe(k, ijk, nf), P.table_mask)) occluded += shade_ao_weight(k);
  }
  const ShadeMaterial m = shade_material(sem_class, sem_instance, ijk, local, nf);
  const vec3 col = shade_fog(shade_surface(m, nrm, -d, sun_vis, shade_ao(occluded), lit), t_sem);
  const vec3 sky = shade_sky_pixel(d);
  if (live) {
    rgba[i - win.first] = surface ? shade_encode(col, 255u) : shade_encode(sky, 0u);
    labels[i - win.first] = surface ? (sem_class << 16u) | (sem_instance & 0xffffu) : 0u;
  }
}
