#version 460
#extension GL_GOOGLE_include_directive : require
// splat_ranges: one invocation per sorted instance; ranges[tile] = [start, end)
// of the tile's run in the sorted key list, written where the tile id changes.
// A key is p.key_words uint32 words with the tile id in the last one: 1 for the
// rasterizer's sorted tile ids, 2 for the LiDAR's 64-bit (tile << 32 | bound)
// keys (little endian: the high word second). The host fills ranges with 0
// first (tiles without Gaussians stay [0, 0)).
// Host modules: engine/splat/rasterizer_gpu.cpp, engine/splat/lidar_gaussians_gpu.cpp;
// tests: tests/splat/test_splat.cpp, tests/splat/test_lidar_gaussians.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatRangesParams p; };
layout(std430, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 1) buffer Ranges { uvec2 ranges[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.n) return;
  const uint w = p.key_words, hi = w - 1u;
  const uint tile = keys[i * w + hi];
  if (i == 0u || keys[(i - 1u) * w + hi] != tile) ranges[tile].x = i;
  if (i + 1u == p.n || keys[(i + 1u) * w + hi] != tile) ranges[tile].y = i + 1u;
}
