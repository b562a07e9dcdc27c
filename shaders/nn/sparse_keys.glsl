// Brick-order keys of voxel coordinates (shared/nn_params.h): for |c| < 2^20
// per axis, ascending 64-bit keys (low, high) = brick order, the order the
// engine's grids and the CPU references (kernels/nn/sparse_cpu.h) keep.
#ifndef ICUBE_SPARSE_KEYS_GLSL
#define ICUBE_SPARSE_KEYS_GLSL

// floor(a / b) per component for b > 0, in integers.
ivec3 icube_floor_div(ivec3 a, ivec3 b) {
  return mix((-a + b - 1) / b * -1, a / b, greaterThanEqual(a, ivec3(0)));
}

uvec2 icube_brick_key(ivec3 c) {
  const uvec3 u = uvec3(c + ivec3(NN_SPARSE_COORD_LIMIT));
  const uvec3 b = u >> 3u, l = u & 7u;
  // key = b.x << 45 | b.y << 27 | b.z << 9 | l.x << 6 | l.y << 3 | l.z (b.* < 2^18)
  const uint lo = (b.z << 9u) | (l.x << 6u) | (l.y << 3u) | l.z | ((b.y & 0x1Fu) << 27u);
  const uint hi = (b.y >> 5u) | (b.x << 13u);
  return uvec2(lo, hi);
}

#endif
