#version 460
#extension GL_GOOGLE_include_directive : require
// resample: the UNet's down/up steps on [planes = batch * channels, X, Y, Z]
// float32, one thread per output element: NN_RS_AVGPOOL2 = mean of the 2x2x2
// block (F.avg_pool3d(2), sizes floored), NN_RS_UPSAMPLE2 = nearest x2
// (F.interpolate(mode="nearest") to twice the size).
// Host module: kernels/nn/resample.{h,cpp}. Tests: tests/nn/test_resample.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_EW_GROUP) in;
layout(push_constant) uniform Push { ResampleParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) writeonly buffer Out { float y_out[]; };

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  const uint X = p.size_x, Y = p.size_y, Z = p.size_z;
  if (p.op == NN_RS_AVGPOOL2) {
    const uint OX = X / 2u, OY = Y / 2u, OZ = Z / 2u;
    if (i >= p.planes * OX * OY * OZ) return;
    const uint oz = i % OZ, oy = (i / OZ) % OY, ox = (i / (OZ * OY)) % OX, pl = i / (OZ * OY * OX);
    float s = 0.0;
    for (uint d = 0u; d < 8u; ++d)
      s += x_in[p.x_offset + ((pl * X + 2u * ox + (d & 1u)) * Y + 2u * oy + ((d >> 1) & 1u)) * Z + 2u * oz + (d >> 2)];
    y_out[p.y_offset + i] = s * 0.125;
  } else {
    const uint OX = 2u * X, OY = 2u * Y, OZ = 2u * Z;
    if (i >= p.planes * OX * OY * OZ) return;
    const uint oz = i % OZ, oy = (i / OZ) % OY, ox = (i / (OZ * OY)) % OX, pl = i / (OZ * OY * OX);
    y_out[p.y_offset + i] = x_in[p.x_offset + ((pl * X + ox / 2u) * Y + oy / 2u) * Z + oz / 2u];
  }
}
