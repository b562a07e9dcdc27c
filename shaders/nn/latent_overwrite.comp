#version 460
#extension GL_GOOGLE_include_directive : require
// latent_overwrite: outpainting's per-step overwrite (conventions §9.3). The
// known latents, noised to the current level with fresh noise,
// sqrt_alpha * known + sqrt_beta * z, replace the model input x where the
// voxel's mask is set; other elements are left alone. Channel-major
// [C][spatial]: element i is voxel i % spatial. One thread per element.
// Host module: kernels/nn/latent_overwrite.{h,cpp}. Tests: tests/nn/test_latent_overwrite.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_DDIM_GROUP) in;
layout(push_constant) uniform Push { LatentOverwriteParams p; };
layout(std430, binding = 0) buffer X { float x[]; };
layout(std430, binding = 1) readonly buffer Known { float known[]; };
layout(std430, binding = 2) readonly buffer Mask { uint mask[]; };
layout(std430, binding = 3) readonly buffer Noise { float z_in[]; };

void main() {
  const uint t = ICUBE_THREAD_LINEAR();
  if (t >= p.count || mask[(p.first + t) % p.spatial - p.mask_base] == 0u) return;
  const uint i = p.offset + t;  // one window of the latent (the same offset in x, known and z)
  precise const float y = p.sqrt_alpha * known[i] + p.sqrt_beta * z_in[i];
  x[i] = y;
}
