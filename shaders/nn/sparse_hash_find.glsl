// The lookup of nn/sparse_hash_insert.comp's table, shared by
// nn/sparse_kernel_map.comp and nn/sparse_lookup.comp: the row whose
// coordinates equal q (linear probing from icube_ijk_hash, full-ijk compare),
// or -1. Include after declaring the buffers `ijk` (int [rows * 3]) and
// `table` (uint [table_size]).
#ifndef ICUBE_SPARSE_HASH_FIND_GLSL
#define ICUBE_SPARSE_HASH_FIND_GLSL
#include "sparse_hash.glsl"

int icube_hash_find(ivec3 q, uint table_size) {
  const uint mask = table_size - 1u;
  uint h = icube_ijk_hash(q) & mask;
  for (uint probe = 0u; probe < table_size; ++probe) {
    const uint s = table[h];
    if (s == 0u) return -1;
    const uint row = s - 1u;
    if (ijk[3u * row] == q.x && ijk[3u * row + 1u] == q.y && ijk[3u * row + 2u] == q.z) return int(row);
    h = (h + 1u) & mask;
  }
  return -1;
}

#endif
