#version 460
#extension GL_GOOGLE_include_directive : require
// view_shade: the viewer's picture from the ray caster's hits, one invocation
// per pixel, packed RGBA8 (R in the low byte) into out_rgba for a copy to an
// R8G8B8A8 image. Modes (shared/view_params.h):
//  shaded   class colour (guidance palette) · (ambient · (0.6 + 0.4·sky) · ao
//           + (1 - ambient) · max(0, n·sun) · lit) with n the world-axis entry
//           face of the hit voxel, sky = 0.5 + 0.5·n.z; with use_vis the
//           visibility word vis[i] (view/rays.comp): lit = 0 when its shadow
//           bit is set, ao = 1 - ao_scale · (AO rays blocked); else lit = ao = 1.
//           Blended into the sky colour by exp2 distance fog on t_sem; sky =
//           gradient by the ray's elevation
//  semantic the guidance palette (sky = palette entry 8), unlit
//  depth    z-depth = t_depth · d_cam.z through a blue-to-yellow ramp over [0, depth_max], none = black
//  instance hashed colour per instance id, class colour darkened for instance 0
//  coords   (ijk mod 64) / 64 as RGB
// palette[c] = 0xAABBGGRR of class c (23 entries); vis: one uint per pixel (bound
// always, read only with use_vis). Host: viewer/view_renderer.cpp.
// Tests: tests/viewer/test_view_shade.cpp.
#include "shared/raycast_params.h"
#include "shared/view_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { ViewShadeParams p; };
layout(std430, binding = 0) readonly buffer Hits { RaycastHit hits[]; };
layout(std430, binding = 1) readonly buffer Palette { uint palette[]; };
layout(std430, binding = 2) writeonly buffer Out { uint out_rgba[]; };
layout(std430, binding = 3) readonly buffer Vis { uint vis[]; };

vec3 unpack_rgb(uint c) { return unpackUnorm4x8(c).rgb; }

vec3 sky(vec3 d) {
  const float e = clamp(d.z, -0.2, 1.0);
  return mix(vec3(0.78, 0.85, 0.93), vec3(0.33, 0.53, 0.82), smoothstep(-0.05, 0.6, e));
}

vec3 ramp(float x) {  // blue -> cyan -> green -> yellow
  x = clamp(x, 0.0, 1.0);
  return clamp(vec3(1.8 * x - 0.6, 0.2 + 0.9 * x, 0.9 - 0.9 * x), 0.0, 1.0);
}

vec3 hash_color(uint id) {
  uint h = id * 2654435761u;
  h ^= h >> 15;
  h *= 2246822519u;
  h ^= h >> 13;
  return vec3(float(h & 255u), float((h >> 8) & 255u), float((h >> 16) & 255u)) / 255.0 * 0.75 + 0.25;
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  const uint n = p.width * p.height;
  if (i >= n) return;
  const RaycastHit h = hits[i];
  const float u = float(i % p.width) + p.pixel_offset, v = float(i / p.width) + p.pixel_offset;
  const vec3 d = normalize(vec3(p.m00 * u + p.m01 * v + p.m02, p.m10 * u + p.m11 * v + p.m12,
                                p.m20 * u + p.m21 * v + p.m22));
  const bool hit = (h.flags & RAYCAST_FLAG_SEM) != 0u;
  vec3 c;
  if (p.mode == VIEW_MODE_SEMANTIC) {
    c = unpack_rgb(palette[hit ? h.sem_class : 0u]);
  } else if (p.mode == VIEW_MODE_DEPTH) {
    const vec2 k = vec2((u - p.cx) / p.fx, (v - p.cy) / p.fy);
    const float dz = 1.0 / sqrt(1.0 + dot(k, k));
    c = h.t_depth > 0.0 ? ramp(h.t_depth * dz / p.depth_max) : vec3(0.0);
  } else if (p.mode == VIEW_MODE_INSTANCE) {
    c = !hit ? vec3(0.0) : h.sem_instance > 0u ? hash_color(h.sem_instance) : 0.3 * unpack_rgb(palette[h.sem_class]);
  } else if (p.mode == VIEW_MODE_COORDS) {
    c = hit ? vec3(ivec3(h.ijk_x, h.ijk_y, h.ijk_z) & 63) / 63.0 : vec3(0.0);
  } else {
    const vec3 s = sky(d);
    if (!hit) {
      c = s;
    } else {
      const int a = abs(h.normal) - 1;
      vec3 nrm = vec3(0.0, 0.0, 1.0);
      if (a >= 0) {
        nrm = vec3(0.0);
        nrm[a] = h.normal > 0 ? 1.0 : -1.0;
      }
      const vec3 sun = vec3(p.sun_x, p.sun_y, p.sun_z);
      const float lambert = max(0.0, dot(nrm, sun));
      const float sky_light = 0.5 + 0.5 * nrm.z;  // faces towards the sky get more ambient
      const vec3 albedo = unpack_rgb(palette[h.sem_class]);
      float sun_vis = 1.0, ao = 1.0;
      if (p.use_vis != 0u) {
        const uint w = vis[i];
        sun_vis = (w & VIEW_VIS_SHADOW_BIT) != 0u ? 0.0 : 1.0;
        ao = 1.0 - p.ao_scale * float(w & VIEW_VIS_AO_MASK);
      }
      const vec3 lit = albedo * (p.ambient * (0.6 + 0.4 * sky_light) * ao + (1.0 - p.ambient) * lambert * sun_vis);
      const float fd = p.fog_density * h.t_sem;
      const float fog = 1.0 - exp2(-fd * fd);
      c = mix(lit, s, clamp(fog, 0.0, 1.0));
    }
  }
  out_rgba[i] = packUnorm4x8(vec4(c, 1.0));
}
