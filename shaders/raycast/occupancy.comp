#version 460
#extension GL_GOOGLE_include_directive : require
// raycast_occupancy: the ray caster's occupancy index over the ray bounds
// (layout: shared/raycast_params.h, RaycastOccupancyParams: (entry, column
// height) word pairs), built from the brick hash table in three dispatches of
// this shader (p.pass), each after a barrier; the host first zero-fills words
// [0, 2 supers + 1) (the super pairs and the block counter) and writes mask_word
// into word 2 supers + 1, where the kernel finds the mask level.
//   RAYCAST_OCC_MARK     one invocation per table slot: its brick's super pair x = 1
//   RAYCAST_OCC_ALLOCATE one invocation per super brick: a marked one takes the next block
//                        (atomic counter; block order is arbitrary, lookups do not depend on it),
//                        stores 1 + block and zeroes the block's pairs
//   RAYCAST_OCC_FILL     one invocation per table slot: its record's mask words copied to the
//                        mask level, its brick's entry in its block,
//                        ((record + 1) << 8) | octant bits of the record's 4³ octants; and, with
//                        h = 1 + its highest occupied z, raises the height word of every super
//                        pair of its 32 x 32 column and of every brick pair of its 8 x 8 column
//                        (in each block of the column's super bricks) to h (atomicMax)
// Bricks outside the bounds' super-brick box are ignored (rays never leave the bounds).
// Host module: engine/render/raycast_gpu.{h,cpp}; test: tests/render/test_raycast.cpp.
#include "shared/world_layout.h"
#include "shared/raycast_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { RaycastOccupancyParams p; };
layout(binding = 0) uniform usamplerBuffer world_table_texels;  // WorldHashEntry slots as R32G32B32A32_UINT
layout(std430, binding = 1) buffer Occupancy { uint occ[]; };
// The brick words as R32_UINT texels: the mask reads are at per-lane addresses (a gather on
// lavapipe, where a storage-buffer load there is a loop over the lanes).
layout(binding = 2) uniform usamplerBuffer brick_words;

// Super word index of table slot i's brick and the brick's place in its block; false when
// the slot is empty or the brick lies outside the box.
bool slot_brick(uint i, out uint sn, out uint local_brick, out uint record, out ivec3 brick) {
  const uvec4 e = texelFetch(world_table_texels, int(i));
  record = e.z;
  sn = 0u;
  local_brick = 0u;
  if (e.z == WORLD_EMPTY_SLOT) return false;
  const uvec3 u = uvec3(e.x & 0x1fffffu, (e.x >> 21u) | ((e.y & 0x3ffu) << 11u), e.y >> 10u);
  const ivec3 b = ivec3(u) - ivec3(WORLD_BRICK_BIAS);
  brick = b;
  const ivec3 ls = (b >> (RAYCAST_SUPER_SHIFT - 3)) - ivec3(p.smin_x, p.smin_y, p.smin_z);
  const uvec3 sdim = uvec3(p.sdim_x, p.sdim_y, p.sdim_z);
  if (any(lessThan(ls, ivec3(0))) || any(greaterThanEqual(uvec3(ls), sdim))) return false;
  sn = uint(ls.x) + sdim.x * (uint(ls.y) + sdim.y * uint(ls.z));
  const ivec3 lb = b & 3;
  local_brick = uint(lb.x + 4 * lb.y + 16 * lb.z);
  return true;
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (p.pass == RAYCAST_OCC_ALLOCATE) {
    if (i >= p.supers || occ[2u * i] == 0u) return;
    const uint k = atomicAdd(occ[2u * p.supers], 1u);
    if (k >= p.max_blocks) return;  // cannot happen: max_blocks >= occupied super bricks (host)
    occ[2u * i] = k + 1u;
    const uint first = p.block_word + k * RAYCAST_BLOCK_WORDS;
    for (uint w = 0u; w < RAYCAST_BLOCK_WORDS; ++w) occ[first + w] = 0u;
    return;
  }
  if (i >= p.slots) return;
  uint sn, local_brick, record;
  ivec3 brick;
  if (!slot_brick(i, sn, local_brick, record, brick)) return;
  if (p.pass == RAYCAST_OCC_MARK) {
    occ[2u * sn] = 1u;
    return;
  }
  // RAYCAST_OCC_FILL. Octant bits of the record: mask word w covers lz = w / 2 and ly in
  // [4 (w % 2), 4 (w % 2) + 4), lx in byte bits 0-3 (ox 0), 4-7 (ox 1).
  const uint base = record * WORLD_BRICK_UINTS + WORLD_MASK_OFFSET;
  uint oct = 0u;
  int top = -1;  // highest occupied local z
  for (uint w = 0u; w < 16u; ++w) {
    const uint m = texelFetch(brick_words, int(base + w)).x;
    occ[p.mask_word + record * RAYCAST_MASK_WORDS + w] = m;
    const uint sh = 2u * (w & 1u) + 4u * (w >> 3u);
    if ((m & 0x0f0f0f0fu) != 0u) oct |= 1u << sh;
    if ((m & 0xf0f0f0f0u) != 0u) oct |= 2u << sh;
    if (m != 0u) top = int(w >> 1u);
  }
  const uint block = occ[2u * sn] - 1u;
  occ[p.block_word + block * RAYCAST_BLOCK_WORDS + 2u * local_brick] = ((record + 1u) << 8u) | oct;
  if (top >= 0) {
    const uint h = uint(brick.z * 8 + top - 32 * p.smin_z + 1);
    const ivec3 ls = (brick >> (RAYCAST_SUPER_SHIFT - 3)) - ivec3(p.smin_x, p.smin_y, p.smin_z);
    const uint lb = uint((brick.x & 3) + 4 * (brick.y & 3));
    for (uint sz = 0u; sz < p.sdim_z; ++sz) {
      const uint s = uint(ls.x) + p.sdim_x * (uint(ls.y) + p.sdim_y * sz);
      atomicMax(occ[2u * s + 1u], h);
      const uint blk = occ[2u * s];  // final after RAYCAST_OCC_ALLOCATE
      if (blk == 0u) continue;
      const uint first = p.block_word + (blk - 1u) * RAYCAST_BLOCK_WORDS + 2u * lb + 1u;
      for (uint lz = 0u; lz < 4u; ++lz) atomicMax(occ[first + 32u * lz], h);
    }
  }
}
