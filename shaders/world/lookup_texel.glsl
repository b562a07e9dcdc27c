// Voxel occupancy in the GPU world through texel fetches (layout:
// shaders/shared/world_layout.h; the storage-buffer version with class and
// instance: world/lookup.glsl). On lavapipe a texel fetch is a gather, where a
// storage-buffer load at a divergent address runs lane by lane, so kernels
// that probe many scattered voxels per invocation (the appearance renderer's
// ambient occlusion) use this. The including shader declares
//   uniform usamplerBuffer world_table_texels;  // WorldHashEntry slots as R32G32B32A32_UINT
//   uniform usamplerBuffer world_brick_texels;  // brick records as R32_UINT
#ifndef ICUBE_WORLD_LOOKUP_TEXEL_GLSL
#define ICUBE_WORLD_LOOKUP_TEXEL_GLSL

#include "shared/world_layout.h"

// Brick record of brick coordinate `brick` (= ijk >> 3), or WORLD_EMPTY_SLOT (the texel form of
// world/lookup.glsl's world_find_brick).
uint world_find_brick_texel(ivec3 brick, uint table_mask) {
  const uvec3 u = uvec3(brick + ivec3(WORLD_BRICK_BIAS));
  const uint lo = u.x | (u.y << 21);
  const uint hi = (u.y >> 11) | (u.z << 10);
  uint slot = world_brick_hash(u.x, u.y, u.z) & table_mask;
  for (uint probe = 0u; probe <= table_mask; ++probe) {
    const uvec4 e = texelFetch(world_table_texels, int(slot));
    if (e.z == WORLD_EMPTY_SLOT) return WORLD_EMPTY_SLOT;
    if (e.x == lo && e.y == hi) return e.z;
    slot = (slot + 1u) & table_mask;
  }
  return WORLD_EMPTY_SLOT;
}

// Whether voxel ijk is occupied (false out of range or in a missing brick).
bool world_occupied_texel(ivec3 ijk, uint table_mask) {
  if (!(all(greaterThanEqual(ijk, ivec3(-WORLD_MAX_IJK - 1))) && all(lessThanEqual(ijk, ivec3(WORLD_MAX_IJK)))))
    return false;
  const uint b = world_find_brick_texel(ijk >> 3, table_mask);
  if (b == WORLD_EMPTY_SLOT) return false;
  const ivec3 l = ijk & ivec3(7);
  const uint n = uint(l.x | (l.y << 3) | (l.z << 6));
  const uint word = texelFetch(world_brick_texels, int(b * WORLD_BRICK_UINTS + WORLD_MASK_OFFSET + (n >> 5u))).x;
  return (word & (1u << (n & 31u))) != 0u;
}

#endif
