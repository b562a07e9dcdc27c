#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_coarse_keys: max pooling's first step, key[r] = the brick-order key
// (shared/nn_params.h) of the coarse voxel floor(ijk[r] / f), value[r] = r,
// for the 64-bit radix sort that groups each coarse voxel's fine rows.
// Host module: kernels/nn/sparse_grid.{h,cpp}. CPU reference: nn::cpu::max_pool.
// Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"
#include "sparse_keys.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseGridParams p; };
layout(std430, binding = 0) readonly buffer Coords { int ijk[]; };
layout(std430, binding = 1) writeonly buffer Keys { uint keys[]; };
layout(std430, binding = 2) writeonly buffer Values { uint values[]; };

void main() {
  const uint r = ICUBE_THREAD_LINEAR();
  if (r >= p.rows) return;
  const ivec3 f = ivec3(p.factor_x, p.factor_y, p.factor_z);
  const ivec3 c = icube_floor_div(ivec3(ijk[3u * r], ijk[3u * r + 1u], ijk[3u * r + 2u]), f);
  const uvec2 k = icube_brick_key(c);
  keys[2u * r] = k.x;
  keys[2u * r + 1u] = k.y;
  values[r] = r;
}
