#version 460
#extension GL_GOOGLE_include_directive : require
// cond_points: scatters map points into one binary occupancy channel of the
// Stage-1 condition volume (conventions §7). Input: grid coordinates
// q = p / vs - 0.5 + 32 (chunk frame, computed in double on the host, stored
// as 3 floats per point); voxel = roundEven(q) (torch.round), dropped outside
// [0, 64)³, cell = 1.0. Plain stores: idempotent, duplicates race harmlessly.
// Host module and CPU reference: engine/world/conditions_gpu.{h,cpp},
// engine/world/conditions.{h,cpp}; test: tests/world/test_conditions.cpp.
#include "shared/conditions_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { CondPointsParams p; };
layout(std430, binding = 0) readonly buffer Points { float pts[]; };
layout(std430, binding = 1) writeonly buffer Volume { float vol[]; };

void main() {
  uint t = ICUBE_THREAD_LINEAR();
  if (t >= p.n) return;
  uint i = p.first + t;
  vec3 r = roundEven(vec3(pts[3 * i], pts[3 * i + 1], pts[3 * i + 2]));
  // Negated test so NaN is dropped too.
  if (!(all(greaterThanEqual(r, vec3(0.0))) && all(lessThan(r, vec3(float(COND_DIM)))))) return;
  uvec3 v = uvec3(r);
  vol[((p.channel * COND_DIM + v.x) * COND_DIM + v.y) * COND_DIM + v.z] = 1.0;
}
