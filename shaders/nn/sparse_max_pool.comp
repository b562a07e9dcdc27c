#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_max_pool: y[c][q] = the maximum of x[c][perm[j]] over coarse row q's
// sorted fine rows j in [begin[q], begin[q + 1]) (the last ends at in_rows);
// features channel-major, one thread per output element; at most 512 children.
// fVDB's definition: -inf start, inactive children skipped (they are not rows).
// Host module: kernels/nn/sparse_grid.{h,cpp}. CPU reference: nn::cpu::max_pool.
// Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseGridParams p; };
layout(binding = 0) uniform samplerBuffer x_tex;  // R32_SFLOAT
layout(std430, binding = 1) readonly buffer Perm { uint perm[]; };
layout(std430, binding = 2) readonly buffer Begin { uint begin[]; };
layout(std430, binding = 3) writeonly buffer Out { float y_out[]; };

void main() {
  const uint id = ICUBE_THREAD_LINEAR();
  if (id >= p.rows * p.channels) return;
  const uint c = id / p.rows, q = id % p.rows;
  const uint b = begin[q], e = q + 1u < p.rows ? begin[q + 1u] : p.in_rows;
  float m = -1.0 / 0.0;
  for (uint j = b; j < e && j < b + 512u; ++j) m = max(m, texelFetch(x_tex, int(p.x_offset + c * p.in_rows + perm[j])).x);
  y_out[p.y_offset + id] = m;
}
