#version 460
#extension GL_GOOGLE_include_directive : require
// raycast_occupancy: the brick and super-brick (32³ voxel) occupancy bit masks
// of the ray caster (layout: shared/raycast_params.h, RaycastOccupancyParams),
// built from the brick hash table: one invocation per table slot ORs the bit
// of its brick and of its super brick, and its brick record's octant byte. The host zero-fills the mask first.
// Slots outside the bounds are ignored (rays never leave the bounds).
// Host module: engine/render/raycast_gpu.{h,cpp}; test: tests/test_raycast.cpp.
#include "shared/world_layout.h"
#include "shared/raycast_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { RaycastOccupancyParams p; };
layout(std430, binding = 0) readonly buffer Table { uvec4 world_table[]; };
layout(std430, binding = 1) buffer Occupancy { uint occ[]; };
layout(std430, binding = 2) readonly buffer Bricks { uint world_bricks[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.slots) return;
  const uvec4 e = world_table[i];
  if (e.z == WORLD_EMPTY_SLOT) return;
  const uvec3 u = uvec3(e.x & 0x1fffffu, (e.x >> 21u) | ((e.y & 0x3ffu) << 11u), e.y >> 10u);
  const ivec3 b = ivec3(u) - ivec3(WORLD_BRICK_BIAS);
  const ivec3 lb = b - ivec3(p.bmin_x, p.bmin_y, p.bmin_z);
  const uvec3 bdim = uvec3(p.bdim_x, p.bdim_y, p.bdim_z);
  if (any(lessThan(lb, ivec3(0))) || any(greaterThanEqual(uvec3(lb), bdim))) return;
  const uint bn = uint(lb.x) + bdim.x * (uint(lb.y) + bdim.y * uint(lb.z));
  atomicOr(occ[bn >> 5u], 1u << (bn & 31u));
  const uvec3 ls = uvec3((b >> (RAYCAST_SUPER_SHIFT - 3)) - ivec3(p.smin_x, p.smin_y, p.smin_z));
  const uint sn = ls.x + p.sdim_x * (ls.y + p.sdim_y * ls.z);
  atomicOr(occ[p.super_word + (sn >> 5u)], 1u << (sn & 31u));
  // Octant byte of brick record e.z: bit ox + 2 oy + 4 oz set when its 4³ octant holds a voxel.
  // Mask word w covers lz = w / 2 and ly in [4 (w % 2), 4 (w % 2) + 4), lx in byte bits 0-3 (ox 0), 4-7 (ox 1).
  const uint base = e.z * WORLD_BRICK_UINTS + WORLD_MASK_OFFSET;
  uint oct = 0u;
  for (uint w = 0u; w < 16u; ++w) {
    const uint m = world_bricks[base + w];
    const uint sh = 2u * (w & 1u) + 4u * (w >> 3u);
    if ((m & 0x0f0f0f0fu) != 0u) oct |= 1u << sh;
    if ((m & 0xf0f0f0f0u) != 0u) oct |= 2u << sh;
  }
  atomicOr(occ[p.oct_word + (e.z >> 2u)], oct << ((e.z & 3u) * 8u));
}
