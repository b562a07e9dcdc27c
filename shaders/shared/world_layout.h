// GPU layout of the sparse semantic voxel world (engine/world/gpu_world.h,
// shaders/world/lookup.glsl). Shared by GLSL and C++.
//
// brick_table: open-addressing hash table of WorldHashEntry, capacity a power
//   of two (load <= 0.5), linear probing from world_brick_hash(ux, uy, uz),
//   where ux = brick x + 2^20 etc. (21 bits each; a brick is floor(ijk / 8)).
//   Key = the packed 63-bit brick coordinate ux | uy << 21 | uz << 42 as
//   (key_lo, key_hi). Empty slots have brick == WORLD_EMPTY_SLOT.
// brick_data: WORLD_BRICK_UINTS uints per brick, at brick * WORLD_BRICK_UINTS:
//   [0, 16)    occupancy mask, bit n of the 512 in uint n / 32 at bit n % 32
//   [16, 144)  classes, 4 per uint (voxel n in byte n % 4 of uint n / 4)
//   [144, 400) instances, 2 per uint (voxel n in half n % 2 of uint n / 2)
//   Voxel n = lx + 8 ly + 64 lz within the brick (x fastest).
#ifndef ICUBE_WORLD_LAYOUT_H
#define ICUBE_WORLD_LAYOUT_H
#include "gpu_types.h"

#define WORLD_EMPTY_SLOT 0xffffffffu
#define WORLD_MASK_OFFSET 0u
#define WORLD_CLASS_OFFSET 16u
#define WORLD_INSTANCE_OFFSET 144u
#define WORLD_BRICK_UINTS 400u
#define WORLD_BRICK_BIAS 1048576
#define WORLD_MAX_IJK 8388607

ICUBE_SHADER_NAMESPACE_BEGIN

struct WorldHashEntry {
  uint key_lo;
  uint key_hi;
  uint brick;  // index into brick_data, WORLD_EMPTY_SLOT when the slot is free
  uint pad0;
};

struct WorldBrickRecord {
  uint mask[16];
  uint classes[128];
  uint instances[256];
};

// world/probe.comp: n query ijks (ivec4, w unused) -> (class, instance) per query.
struct WorldProbeParams {
  uint n;
  uint table_mask;  // capacity - 1
  uint pad0;
  uint pad1;
};

#ifdef __cplusplus
#define WORLD_FN inline
#else
#define WORLD_FN
#endif

// Slot hash of a biased brick coordinate (32-bit multiply-xor, murmur3 finaliser).
WORLD_FN uint world_brick_hash(uint ux, uint uy, uint uz) {
  uint h = (ux * 0x9E3779B1u) ^ (uy * 0x85EBCA77u) ^ (uz * 0xC2B2AE3Du);
  h ^= h >> 16;
  h *= 0x7FEB352Du;
  h ^= h >> 15;
  h *= 0x846CA68Bu;
  h ^= h >> 16;
  return h;
}

ICUBE_SHADER_NAMESPACE_END

ICUBE_CHECK_SIZE(WorldHashEntry, 16);
ICUBE_CHECK_LAYOUT(WorldHashEntry, key_hi, 4);
ICUBE_CHECK_LAYOUT(WorldHashEntry, brick, 8);
ICUBE_CHECK_SIZE(WorldBrickRecord, 400 * 4);
ICUBE_CHECK_LAYOUT(WorldBrickRecord, classes, 16 * 4);
ICUBE_CHECK_LAYOUT(WorldBrickRecord, instances, 144 * 4);
ICUBE_CHECK_SIZE(WorldProbeParams, 16);
ICUBE_CHECK_LAYOUT(WorldProbeParams, table_mask, 4);

#endif
