// Voxel lookups in the GPU world (layout: shaders/shared/world_layout.h,
// host side: engine/world/gpu_world.h). The including shader declares, before
// including this file,
//   buffer ... { uvec4 world_table[]; };   // WorldHashEntry slots
//   buffer ... { uint world_bricks[]; };   // WORLD_BRICK_UINTS per brick
// and passes the table's capacity - 1 as `table_mask`.
#ifndef ICUBE_WORLD_LOOKUP_GLSL
#define ICUBE_WORLD_LOOKUP_GLSL

#include "shared/world_layout.h"

bool world_ijk_in_range(ivec3 ijk) {
  return all(greaterThanEqual(ijk, ivec3(-WORLD_MAX_IJK - 1))) && all(lessThanEqual(ijk, ivec3(WORLD_MAX_IJK)));
}

// Brick index of brick coordinate `brick` (= ijk >> 3), or WORLD_EMPTY_SLOT.
uint world_find_brick(ivec3 brick, uint table_mask) {
  uvec3 u = uvec3(brick + ivec3(WORLD_BRICK_BIAS));
  uint lo = u.x | (u.y << 21);
  uint hi = (u.y >> 11) | (u.z << 10);
  uint slot = world_brick_hash(u.x, u.y, u.z) & table_mask;
  for (uint probe = 0u; probe <= table_mask; ++probe) {
    uvec4 e = world_table[slot];
    if (e.z == WORLD_EMPTY_SLOT) return WORLD_EMPTY_SLOT;
    if (e.x == lo && e.y == hi) return e.z;
    slot = (slot + 1u) & table_mask;
  }
  return WORLD_EMPTY_SLOT;
}

// (class, instance) of voxel ijk; (0, 0) when empty or out of range.
uvec2 world_voxel(ivec3 ijk, uint table_mask) {
  if (!world_ijk_in_range(ijk)) return uvec2(0u);
  uint b = world_find_brick(ijk >> 3, table_mask);
  if (b == WORLD_EMPTY_SLOT) return uvec2(0u);
  ivec3 l = ijk & ivec3(7);
  uint n = uint(l.x | (l.y << 3) | (l.z << 6));
  uint base = b * WORLD_BRICK_UINTS;
  if ((world_bricks[base + WORLD_MASK_OFFSET + (n >> 5u)] & (1u << (n & 31u))) == 0u) return uvec2(0u);
  uint cls = (world_bricks[base + WORLD_CLASS_OFFSET + (n >> 2u)] >> ((n & 3u) * 8u)) & 0xffu;
  uint inst = (world_bricks[base + WORLD_INSTANCE_OFFSET + (n >> 1u)] >> ((n & 1u) * 16u)) & 0xffffu;
  return uvec2(cls, inst);
}

uint world_voxel_class(ivec3 ijk, uint table_mask) { return world_voxel(ijk, table_mask).x; }
uint world_voxel_instance(ivec3 ijk, uint table_mask) { return world_voxel(ijk, table_mask).y; }

#endif
