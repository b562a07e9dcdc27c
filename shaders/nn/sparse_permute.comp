#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_permute: the children in brick order after the radix sort,
// out_ijk[i] = in_ijk[perm[i]] and out_parent[i] = in_parent[perm[i]].
// Host module: kernels/nn/sparse_grid.{h,cpp}. Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseGridParams p; };
layout(std430, binding = 0) readonly buffer Perm { uint perm[]; };
layout(std430, binding = 1) readonly buffer InCoords { int in_ijk[]; };
layout(std430, binding = 2) readonly buffer InParents { uint in_parent[]; };
layout(std430, binding = 3) writeonly buffer OutCoords { int out_ijk[]; };
layout(std430, binding = 4) writeonly buffer OutParents { uint out_parent[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.rows) return;
  const uint j = perm[i];
  out_ijk[3u * i] = in_ijk[3u * j];
  out_ijk[3u * i + 1u] = in_ijk[3u * j + 1u];
  out_ijk[3u * i + 2u] = in_ijk[3u * j + 2u];
  out_parent[i] = in_parent[j];
}
