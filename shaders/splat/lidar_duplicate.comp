#version 460
#extension GL_GOOGLE_include_directive : require
// splat_lidar_duplicate: one invocation per Gaussian; writes one (key, value)
// instance per range-image tile its rect (splat/lidar_bin.comp) covers, at
// offsets[i] − touched[i] (offsets = inclusive scan of touched): key = (low
// word: the float bits of the non-negative t* lower bound, high word: tile =
// ty · tiles_x + tx), value = the Gaussian index. Tile columns run from tx0
// for `count` tiles modulo tiles_x (the azimuth wrap).
// Host module: engine/splat/lidar_gaussians_gpu.cpp; test: tests/splat/test_lidar_gaussians.cpp.
#include "shared/splat_lidar_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatLidarParams p; };
layout(std430, binding = 0) readonly buffer Rects { uvec4 rects[]; };
layout(std430, binding = 1) readonly buffer Touched { uint touched[]; };
layout(std430, binding = 2) readonly buffer Offsets { uint offsets[]; };
layout(std430, binding = 3) readonly buffer Bound { float bound[]; };
layout(std430, binding = 4) writeonly buffer Keys { uvec2 keys[]; };
layout(std430, binding = 5) writeonly buffer Values { uint values[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.n) return;
  const uint n = touched[i];
  if (n == 0u) return;
  const uvec4 rect = rects[i];
  const uint lo = floatBitsToUint(bound[i]);
  uint o = offsets[i] - n;
  for (uint ty = rect.x; ty <= rect.y; ++ty) {
    for (uint k = 0u; k < rect.w; ++k) {
      uint tx = rect.z + k;
      if (tx >= p.tiles_x) tx -= p.tiles_x;
      keys[o] = uvec2(lo, ty * p.tiles_x + tx);
      values[o] = i;
      ++o;
    }
  }
}
