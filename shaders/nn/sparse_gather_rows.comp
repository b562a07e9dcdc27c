#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_gather_rows: features of other rows, y[c][i] = x[c][rows[i]], or 0
// where rows[i] < 0; channel-major [C][rows] on both sides, one thread per
// output element. Subdivision copies each parent's features to its children
// with it, and dense boxes fill from sparse grids (rows from a lookup).
// Host module: kernels/nn/sparse_grid.{h,cpp}. Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseGridParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT
layout(std430, binding = 1) readonly buffer Rows { int rows[]; };
layout(std430, binding = 2) writeonly buffer Out { float y_out[]; };

void main() {
  const uint id = ICUBE_THREAD_LINEAR();
  if (id >= p.rows * p.channels) return;
  const uint c = id / p.rows, i = id % p.rows;
  const int r = rows[i];
  const float v = texelFetch(x_tex, int(p.x_offset + c * p.in_rows + uint(max(r, 0)))).x;
  y_out[p.y_offset + id] = r >= 0 ? v : 0.0;
}
