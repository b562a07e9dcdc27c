#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_hash_insert: every row of a sparse grid into an open-addressing
// table (slot = row + 1, 0 empty; linear probing from icube_ijk_hash; the
// table, a power of two at least twice the rows, starts zeroed). Rows are
// unique, so an insert only claims the first empty slot (atomicCompSwap); the
// table's layout depends on the race, the lookups' answers do not.
// Host module: kernels/nn/sparse_conv.{h,cpp} (SparseKernelMap). CPU reference:
// nn::cpu::kernel_map (kernels/nn/sparse_cpu.h). Tests: tests/nn/test_sparse_conv.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"
#include "sparse_hash.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseHashParams p; };
layout(std430, binding = 0) readonly buffer Coords { int ijk[]; };
layout(std430, binding = 1) buffer Table { uint table[]; };

void main() {
  const uint r = ICUBE_THREAD_LINEAR();
  if (r >= p.rows) return;
  const ivec3 c = ivec3(ijk[3u * r], ijk[3u * r + 1u], ijk[3u * r + 2u]);
  const uint mask = p.table_size - 1u;
  uint h = icube_ijk_hash(c) & mask;
  for (uint probe = 0u; probe < p.table_size; ++probe) {
    if (atomicCompSwap(table[h], 0u, r + 1u) == 0u) return;
    h = (h + 1u) & mask;
  }
}
