#version 460
#extension GL_GOOGLE_include_directive : require
// splat_tile_ranges: one invocation per sorted instance; ranges[tile] = [start, end)
// of the tile's run in the sorted tile-id list (uint32 per instance), written
// where the tile id changes. The host fills ranges with 0 first (tiles without
// Gaussians stay [0, 0)). The 64-bit-key variant is splat_ranges.comp (LiDAR).
// Host module: engine/splat/rasterizer_gpu.cpp; test: tests/test_splat.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatRangesParams p; };
layout(std430, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, binding = 1) buffer Ranges { uvec2 ranges[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.n) return;
  const uint tile = keys[i];
  if (i == 0u || keys[i - 1u] != tile) ranges[tile].x = i;
  if (i + 1u == p.n || keys[i + 1u] != tile) ranges[tile].y = i + 1u;
}
