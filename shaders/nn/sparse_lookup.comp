#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_lookup: rows[i] = the row of query coordinate i in a grid hashed by
// nn/sparse_hash_insert.comp, or -1 (e.g. the VAE's dense neck box filled
// from the encoder's sparse grid).
// Host module: kernels/nn/sparse_grid.{h,cpp}. CPU reference: nn::cpu::find_rows.
// Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseHashParams p; };  // rows = queries
layout(std430, binding = 0) readonly buffer Coords { int ijk[]; };
layout(std430, binding = 1) readonly buffer Table { uint table[]; };
layout(std430, binding = 2) readonly buffer Queries { int query[]; };
layout(std430, binding = 3) writeonly buffer Rows { int rows[]; };
#include "sparse_hash_find.glsl"

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.rows) return;
  const ivec3 q = ivec3(query[3u * i], query[3u * i + 1u], query[3u * i + 2u]);
  rows[i] = icube_hash_find(q, p.table_size);
}
