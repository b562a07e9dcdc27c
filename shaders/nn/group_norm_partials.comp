#version 460
#extension GL_GOOGLE_include_directive : require
// group_norm_partials: pass 1 of GroupNorm. Thread t = (batch-group bg, chunk c)
// runs Welford over the group's elements c, c + chunks, c + 2 chunks, ...
// (consecutive threads read consecutive elements), shifted by the group's
// first element (so a large common offset does not cost precision), and
// writes (mean, M2, count, shift) of x - shift to partials[bg * chunks + c].
// fp32; Welford keeps a constant group's M2 and mean at exactly 0.
// A group larger than one binding runs as several dispatches, each over the
// group's elements [span_begin, span_end) (the window starts at span_begin):
// the first writes the triples, the later ones (NN_GN_FLAG_CONTINUE) continue
// them, taking the shift from the stored partial.
// Host module: kernels/nn/group_norm.{h,cpp}. Tests: tests/nn/test_group_norm.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_GN_GROUP) in;
layout(push_constant) uniform Push { GroupNormParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) buffer Partials { vec4 partials[]; };

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  const uint bg = t / p.chunks, c = t % p.chunks;
  if (bg >= p.batch * p.groups) return;
  const uint n = p.channels / p.groups * p.spatial;
  // x_in[base + i] is the group's element i (i in [span_begin, span_end)).
  const uint base = p.x_offset + bg * n - p.span_begin;
  float mean = 0.0, m2 = 0.0, count = 0.0, shift;
  if ((p.flags & NN_GN_FLAG_CONTINUE) != 0u) {
    const vec4 q = partials[t];
    mean = q.x;
    m2 = q.y;
    count = q.z;
    shift = q.w;
  } else {
    shift = x_in[base + p.span_begin];
  }
  // The first element >= span_begin that belongs to chunk c.
  const uint first = p.span_begin + (c + p.chunks - p.span_begin % p.chunks) % p.chunks;
  for (uint i = first; i < p.span_end; i += p.chunks) {
    const float v = x_in[base + i] - shift;
    count += 1.0;
    const float d = v - mean;
    mean += d / count;
    m2 += d * (v - mean);
  }
  partials[t] = vec4(mean, m2, count, shift);
}
