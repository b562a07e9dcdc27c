#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_children: structure subdivision, one thread per (parent row, child
// o). A kept parent r (keep[r] = 1; incl = inclusive scan of keep) writes its
// child (incl[r] - 1) * F + o, F = fx * fy * fz, o = (a * fy + b) * fz + c:
// coordinates ijk[r] * f + (a, b, c), parent r, and the child's brick-order
// key (shared/nn_params.h) as two uints (low, high) for the 64-bit radix sort.
// Coordinates stay within +-2^20 (the host checks the level's bounds).
// Host module: kernels/nn/sparse_grid.{h,cpp}. CPU reference: nn::cpu::subdivide.
// Tests: tests/nn/test_sparse_grid.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"
#include "sparse_keys.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseGridParams p; };
layout(std430, binding = 0) readonly buffer Coords { int ijk[]; };
layout(std430, binding = 1) readonly buffer Keep { uint keep[]; };
layout(std430, binding = 2) readonly buffer Incl { uint incl[]; };
layout(std430, binding = 3) writeonly buffer ChildCoords { int child_ijk[]; };
layout(std430, binding = 4) writeonly buffer Parents { uint parent[]; };
layout(std430, binding = 5) writeonly buffer Keys { uint keys[]; };

void main() {
  const uint F = p.factor_x * p.factor_y * p.factor_z;
  const uint id = ICUBE_THREAD_LINEAR();
  if (id >= p.rows * F) return;
  const uint r = id / F, o = id % F;
  if (keep[r] == 0u) return;
  const uint child = (incl[r] - 1u) * F + o;
  const ivec3 off = ivec3(int(o / (p.factor_y * p.factor_z)), int((o / p.factor_z) % p.factor_y), int(o % p.factor_z));
  const ivec3 c = ivec3(ijk[3u * r], ijk[3u * r + 1u], ijk[3u * r + 2u]) * ivec3(p.factor_x, p.factor_y, p.factor_z) + off;
  child_ijk[3u * child] = c.x;
  child_ijk[3u * child + 1u] = c.y;
  child_ijk[3u * child + 2u] = c.z;
  parent[child] = r;
  const uvec2 k = icube_brick_key(c);
  keys[2u * child] = k.x;
  keys[2u * child + 1u] = k.y;
}
