#version 460
#extension GL_GOOGLE_include_directive : require
// world_probe: results[i] = (class, instance) of voxel queries[i].xyz in the
// GPU world, (0, 0) when empty or out of range. A test kernel for the lookup
// functions in world/lookup.glsl (layout: shared/world_layout.h).
// Host module: engine/world/gpu_world.{h,cpp}; test: tests/world/test_world_gpu.cpp.
#include "shared/world_layout.h"
#include "common/dispatch.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { WorldProbeParams p; };
layout(std430, binding = 0) readonly buffer Table { uvec4 world_table[]; };
layout(std430, binding = 1) readonly buffer Bricks { uint world_bricks[]; };
layout(std430, binding = 2) readonly buffer Queries { ivec4 queries[]; };
layout(std430, binding = 3) writeonly buffer Results { uvec2 results[]; };

#include "world/lookup.glsl"

void main() {
  uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.n) return;
  results[i] = world_voxel(queries[i].xyz, p.table_mask);
}
