#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_kernel_map: the neighbour map of a submanifold 3^3 convolution, one
// thread per (row, tap): kmap[row * 27 + tap] = the row at ijk[row] + (a, b,
// c) - 1 with tap = (a * 3 + b) * 3 + c (grid order: a along i), or -1; by
// probing the table of nn/sparse_hash_insert.comp and comparing full ijk.
// Rows [row_begin, row_begin + row_count) per dispatch, kmap bound from
// row_begin's entries (kernel maps beyond one binding run in row windows).
// Host module: kernels/nn/sparse_conv.{h,cpp} (SparseKernelMap). CPU reference:
// nn::cpu::kernel_map. Tests: tests/nn/test_sparse_conv.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_SPARSE_GROUP) in;
layout(push_constant) uniform Push { SparseHashParams p; };
layout(std430, binding = 0) readonly buffer Coords { int ijk[]; };
layout(std430, binding = 1) readonly buffer Table { uint table[]; };
layout(std430, binding = 2) writeonly buffer Map { int kmap[]; };
#include "sparse_hash_find.glsl"

void main() {
  const uint id = ICUBE_THREAD_LINEAR();  // (row - row_begin) * 27 + tap
  if (id >= p.row_count * NN_SPARSE_TAPS) return;
  const uint r = p.row_begin + id / NN_SPARSE_TAPS, tap = id % NN_SPARSE_TAPS;
  const ivec3 q = ivec3(ijk[3u * r], ijk[3u * r + 1u], ijk[3u * r + 2u]) +
                  ivec3(int(tap / 9u), int((tap / 3u) % 3u), int(tap % 3u)) - ivec3(1);
  kmap[id] = icube_hash_find(q, p.table_size);
}
