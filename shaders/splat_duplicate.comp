#version 460
#extension GL_GOOGLE_include_directive : require
// splat_duplicate: one invocation per Gaussian; writes one (key, value) per
// tile of its rect, row-major over the rect, at offsets from the inclusive
// scan of touched[] (no atomics, so the order is deterministic).
// key = uvec2(float bits of view z, tile id) = tile_id << 32 | depth bits as a
// little-endian uint64; value = Gaussian index. z > near > 0, so the float
// bits order like the depths.
// Host module: engine/splat/rasterizer_gpu.cpp; test: tests/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatDuplicateParams p; };
layout(std430, binding = 0) readonly buffer Proj { vec4 proj[]; };
layout(std430, binding = 1) readonly buffer Rects { uvec4 rects[]; };
layout(std430, binding = 2) readonly buffer Touched { uint touched[]; };
layout(std430, binding = 3) readonly buffer Offsets { uint offsets_incl[]; };
layout(std430, binding = 4) writeonly buffer Keys { uvec2 keys[]; };
layout(std430, binding = 5) writeonly buffer Values { uint values[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.n) return;
  const uint count = touched[i];
  if (count == 0u) return;
  uint o = offsets_incl[i] - count;
  const uvec4 r = rects[i];
  const uint zbits = floatBitsToUint(proj[3u * i].z);
  for (uint y = r.y; y < r.w; ++y)
    for (uint x = r.x; x < r.z; ++x) {
      keys[o] = uvec2(zbits, y * p.grid_x + x);
      values[o] = i;
      ++o;
    }
}
