#version 460
#extension GL_GOOGLE_include_directive : require
// view_rays: the viewer's shadow and ambient-occlusion rays, one invocation
// per pixel, for the ray caster's ray-list mode (shaders/raycast/cast.comp), and
// the per-pixel visibility word that view/shade.comp reads
// (shared/view_params.h). One dispatch per ray pass; flags (in this order):
//  INIT        vis[i] = 0
//  ACCUMULATE  the previous pass's result prev[i] (RaycastHit) blocked the ray
//              (semantic hit) -> vis[i] += PREV_SHADOW ? VIEW_VIS_SHADOW_BIT : 1
//  GENERATE    rays[2i], rays[2i+1] = origin (relative to ref, voxel units), unit direction
// Origin: on the entry face of the camera ray's semantic voxel v = ijk - ref
// (axis a = |normal| - 1, outward sign s): coordinate a = the face plane + s·2e-3
// (just outside, in the empty neighbour), the other axes = the camera ray's hit
// point off + t_sem·d/vs clamped to [v + 1e-3, v + 1 - 1e-3]. Directions:
//  shadow  the sun, only where n·sun > 0 (else no ray)
//  AO      cosine-weighted about n, sample s of K with a fixed per-pixel pattern:
//          (r1, r2) = view_pixel_hash(x, y), u = (s + r2) / K, phi = 2π·fract(r1 + 0.618034·s),
//          d = sqrt(u)·(cos phi·t1 + sin phi·t2) + sqrt(1 - u)·n, t1 = axis (a+1)%3, t2 = axis (a+2)%3
//          (engine twin: viewer/view_renderer.h ao_direction)
// "No ray" (no camera hit, the camera inside a voxel, a face turned from the
// sun) is the origin (-1e30, 0, 0) with direction +z, which the ray caster
// rejects at once (outside the bounds on an axis it does not move along).
// Host: viewer/view_renderer.cpp. Tests: tests/viewer/test_view_shade.cpp.
#include "shared/raycast_params.h"
#include "shared/view_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { ViewRaysParams p; };
layout(std430, binding = 0) readonly buffer Hits { RaycastHit hits[]; };
layout(std430, binding = 1) readonly buffer Prev { RaycastHit prev[]; };
layout(std430, binding = 2) buffer Vis { uint vis[]; };
layout(std430, binding = 3) writeonly buffer Rays { vec4 rays[]; };

uint view_hash(uint x, uint y) {
  uint h = (x * 73856093u) ^ (y * 19349663u);
  h ^= h >> 16u;
  h *= 0x7feb352du;
  h ^= h >> 15u;
  h *= 0x846ca68bu;
  h ^= h >> 16u;
  return h;
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.width * p.height) return;
  if ((p.flags & (VIEW_RAYS_INIT | VIEW_RAYS_ACCUMULATE)) != 0u) {
    uint w = (p.flags & VIEW_RAYS_INIT) != 0u ? 0u : vis[i];
    if ((p.flags & VIEW_RAYS_ACCUMULATE) != 0u && (prev[i].flags & RAYCAST_FLAG_SEM) != 0u)
      w += (p.flags & VIEW_RAYS_PREV_SHADOW) != 0u ? VIEW_VIS_SHADOW_BIT : 1u;
    vis[i] = w;
  }
  if ((p.flags & VIEW_RAYS_GENERATE) == 0u) return;

  vec3 o = vec3(-1.0e30, 0.0, 0.0), d = vec3(0.0, 0.0, 1.0);
  const RaycastHit h = hits[i];
  if ((h.flags & RAYCAST_FLAG_SEM) != 0u && h.normal != RAYCAST_NORMAL_NONE) {
    const int a = abs(h.normal) - 1;
    const float sg = h.normal > 0 ? 1.0 : -1.0;
    vec3 n = vec3(0.0);
    n[a] = sg;
    const uint px = i % p.width, py = i / p.width;
    const float u = float(px) + p.pixel_offset, v = float(py) + p.pixel_offset;
    const vec3 dc = normalize(vec3(p.m00 * u + p.m01 * v + p.m02, p.m10 * u + p.m11 * v + p.m12,
                                   p.m20 * u + p.m21 * v + p.m22));
    const ivec3 rel = ivec3(h.ijk_x, h.ijk_y, h.ijk_z) - ivec3(p.ref_x, p.ref_y, p.ref_z);
    const vec3 hp = vec3(p.off_x, p.off_y, p.off_z) + h.t_sem * p.inv_voxel * dc;
    vec3 org = clamp(hp, vec3(rel) + 1.0e-3, vec3(rel) + (1.0 - 1.0e-3));
    org[a] = float(sg > 0.0 ? rel[a] + 1 : rel[a]) + sg * 2.0e-3;
    const vec3 sun = vec3(p.sun_x, p.sun_y, p.sun_z);
    if (p.kind == VIEW_RAYS_KIND_SHADOW) {
      if (dot(n, sun) > 0.0) {
        o = org;
        d = sun;
      }
    } else {
      const uint hh = view_hash(px, py);
      const float r1 = float(hh & 0xffffu) / 65536.0, r2 = float(hh >> 16u) / 65536.0;
      const float uu = (float(p.sample_index) + r2) / float(p.samples);
      const float phi = 6.28318530718 * fract(r1 + 0.618034 * float(p.sample_index));
      vec3 t1 = vec3(0.0), t2 = vec3(0.0);
      t1[(a + 1) % 3] = 1.0;
      t2[(a + 2) % 3] = 1.0;
      const float r = sqrt(uu);
      o = org;
      d = normalize(r * cos(phi) * t1 + r * sin(phi) * t2 + sqrt(max(0.0, 1.0 - uu)) * n);
    }
  }
  rays[2u * i] = vec4(o, 0.0);
  rays[2u * i + 1u] = vec4(d, 0.0);
}
