#version 460
#extension GL_GOOGLE_include_directive : require
// iota: out[i] = start + i * step (uint32, wrapping) for i < n.
// Used to make payload indices for key-value sorts; its 1-D dispatch is
// folded into 2-D past 65,535 workgroups, so it also exercises that path.
// Host module and CPU reference: kernels/fill.{h,cpp}. Tests: tests/primitives/test_fill.cpp.
#include "shared/primitives_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { IotaParams p; };
layout(std430, binding = 0) writeonly buffer Out { uint data_out[]; };

void main() {
  uint i = ICUBE_THREAD_LINEAR();
  if (i < p.n) data_out[i] = p.start + i * p.step;
}
