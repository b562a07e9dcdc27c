#version 460
#extension GL_GOOGLE_include_directive : require
// splat_to_rgba8: the rasterizer's image (splat/blend.comp: 4 floats per pixel,
// colour + T·sky in RGB) as packed RGBA8 for a copy to an R8G8B8A8 image (R in
// the low byte, alpha 255): each channel v = floor(clamp(c, 0, 1)·255 + 0.5),
// NaN -> 0 (the host's splat_rgb8 rounds alike). One invocation per pixel.
// Host module: engine/splat/splat_rgba8.cpp; tests: tests/splat/test_splat_rgba8.cpp.
#include "shared/splat_params.h"
#include "common/dispatch.glsl"

layout(local_size_x_id = 0) in;
layout(push_constant) uniform Push { SplatToRgba8Params p; };
layout(std430, binding = 0) readonly buffer Image { vec4 image[]; };
layout(std430, binding = 1) writeonly buffer Out { uint out_rgba[]; };

uint channel(float c) {
  if (isnan(c)) return 0u;
  return uint(floor(clamp(c, 0.0, 1.0) * 255.0 + 0.5));
}

void main() {
  const uint i = ICUBE_THREAD_LINEAR();
  if (i >= p.pixels) return;
  const vec4 c = image[i];
  out_rgba[i] = channel(c.r) | (channel(c.g) << 8) | (channel(c.b) << 16) | 0xff000000u;
}
