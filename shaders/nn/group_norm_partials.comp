#version 460
#extension GL_GOOGLE_include_directive : require
// group_norm_partials: pass 1 of GroupNorm. Thread t = (batch-group bg, chunk c)
// runs Welford over the group's elements c, c + chunks, c + 2 chunks, ...
// (consecutive threads read consecutive elements), shifted by the group's
// first element (so a large common offset does not cost precision), and
// writes (mean, M2, count) of x - shift to partials[bg * chunks + c]. fp32;
// Welford keeps a constant group's M2 and mean at exactly 0.
// Host module: kernels/nn/group_norm.{h,cpp}. Tests: tests/nn/test_group_norm_gpu.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_GN_GROUP) in;
layout(push_constant) uniform Push { GroupNormParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) writeonly buffer Partials { vec4 partials[]; };

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  const uint bg = t / p.chunks, c = t % p.chunks;
  if (bg >= p.batch * p.groups) return;
  const uint n = p.channels / p.groups * p.spatial;
  const uint base = p.x_offset + bg * n;  // (b * C + g * C/G) * S in the window
  const float shift = x_in[base];
  float mean = 0.0, m2 = 0.0, count = 0.0;
  for (uint i = c; i < n; i += p.chunks) {
    const float v = x_in[base + i] - shift;
    count += 1.0;
    const float d = v - mean;
    mean += d / count;
    m2 += d * (v - mean);
  }
  partials[t] = vec4(mean, m2, count, 0.0);
}
