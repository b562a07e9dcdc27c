#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_coarse_rows: the coarsened grid, one thread per sorted fine row i;
// where starts[i] = 1 the coarse row q = incl[i] - 1 (incl = inclusive scan of
// starts) begins: begin[q] = i and its ijk = floor(ijk[perm[i]] / f). The
// coarse rows come out in brick order (the sort's).
// Host module: kernels/nn/sparse_grid.{h,cpp}. CPU reference: nn::cpu::max_pool.
// Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"
#include "sparse_keys.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseGridParams p; };
layout(std430, binding = 0) readonly buffer Coords { int ijk[]; };
layout(std430, binding = 1) readonly buffer Perm { uint perm[]; };
layout(std430, binding = 2) readonly buffer Starts { uint starts[]; };
layout(std430, binding = 3) readonly buffer Incl { uint incl[]; };
layout(std430, binding = 4) writeonly buffer Begin { uint begin[]; };
layout(std430, binding = 5) writeonly buffer CoarseCoords { int coarse_ijk[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.rows || starts[i] == 0u) return;
  const uint q = incl[i] - 1u, r = perm[i];
  const ivec3 c = icube_floor_div(ivec3(ijk[3u * r], ijk[3u * r + 1u], ijk[3u * r + 2u]),
                                  ivec3(p.factor_x, p.factor_y, p.factor_z));
  begin[q] = i;
  coarse_ijk[3u * q] = c.x;
  coarse_ijk[3u * q + 1u] = c.y;
  coarse_ijk[3u * q + 2u] = c.z;
}
