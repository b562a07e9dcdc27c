#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_keep: the structure decision of InfiniCube's VAE heads, keep[r] = 1
// when logits[0][r] > logits[1][r] (channel 0 = exists; logits channel-major
// [2][rows]), else 0; NaN logits drop the voxel. A dispatch covers p.rows
// rows of a window: each channel's logits and the output bound at their own
// offsets (x_offset, x1_offset, y_offset), so logits over one storage binding
// run as several dispatches.
// Host module: kernels/nn/sparse_grid.{h,cpp}. CPU reference: VaeReference::decode
// (engine/nn/vae_reference.cpp). Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseGridParams p; };
layout(std430, binding = 0) readonly buffer Exists { float logits0[]; };
layout(std430, binding = 1) readonly buffer Empty { float logits1[]; };
layout(std430, binding = 2) writeonly buffer Keep { uint keep[]; };

void main() {
  const uint r = ICUBE_THREAD_LINEAR();
  if (r >= p.rows) return;
  keep[p.y_offset + r] = logits0[p.x_offset + r] > logits1[p.x1_offset + r] ? 1u : 0u;
}
