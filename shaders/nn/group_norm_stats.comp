#version 460
#extension GL_GOOGLE_include_directive : require
// group_norm_stats: pass 2 of GroupNorm. Thread bg combines the group's
// `chunks` Welford partials (Chan et al.'s parallel update, deviations from
// the group's first element, which every partial carries in .w) and writes
// stats[bg] = (shift, mean deviation, 1 / sqrt(var + eps), 0), var the biased
// variance as torch.nn.GroupNorm uses it.
// Host module: kernels/nn/group_norm.{h,cpp}. Tests: tests/nn/test_group_norm.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_GN_GROUP) in;
layout(push_constant) uniform Push { GroupNormParams p; };
layout(std430, binding = 0) readonly buffer Partials { vec4 partials[]; };
layout(std430, binding = 1) writeonly buffer Stats { vec4 stats[]; };

void main() {
  const uint bg = ICUBE_THREAD_LINEAR();
  if (bg >= p.batch * p.groups) return;
  float mean = 0.0, m2 = 0.0, count = 0.0;
  for (uint c = 0u; c < p.chunks; ++c) {
    const vec4 q = partials[bg * p.chunks + c];
    if (q.z == 0.0) continue;
    const float total = count + q.z;
    const float d = q.x - mean;
    mean += d * (q.z / total);
    m2 += q.y + d * d * (count * q.z / total);
    count = total;
  }
  stats[bg] = vec4(partials[bg * p.chunks].w, mean, inversesqrt(max(m2, 0.0) / count + p.eps), 0.0);
}
