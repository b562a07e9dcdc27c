// Coordinate hash of the sparse voxel tables (nn/sparse_hash_insert.comp,
// nn/sparse_kernel_map.comp): a 32-bit mix of all three int32 coordinates.
// Slots hold row + 1 and lookups compare the full ijk, so collisions cost
// probes, never wrong rows.
#ifndef ICUBE_SPARSE_HASH_GLSL
#define ICUBE_SPARSE_HASH_GLSL

uint icube_ijk_hash(ivec3 c) {
  uint h = uint(c.x) * 0x9E3779B1u;
  h = (h ^ (h >> 15)) + uint(c.y) * 0x85EBCA77u;
  h = (h ^ (h >> 13)) + uint(c.z) * 0xC2B2AE3Du;
  h ^= h >> 16;
  h *= 0x7FEB352Du;
  h ^= h >> 15;
  h *= 0x846CA68Bu;
  h ^= h >> 16;
  return h;
}

#endif
