#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_segments: after the coarse keys are sorted, starts[i] = 1 where key i
// differs from key i - 1 (and at i = 0): the first fine row of each coarse voxel.
// Host module: kernels/nn/sparse_grid.{h,cpp}. Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseGridParams p; };
layout(std430, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 1) writeonly buffer Starts { uint starts[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.rows) return;
  starts[i] = i == 0u || keys[2u * i] != keys[2u * i - 2u] || keys[2u * i + 1u] != keys[2u * i - 1u] ? 1u : 0u;
}
