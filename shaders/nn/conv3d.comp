#version 460
#extension GL_GOOGLE_include_directive : require
// conv3d: y[b, co, v] = bias[co] + sum_{ci, tap} w[co, ci, tap] * x[b, ci, v + tap - k/2],
// dense NCDHW float32, stride 1, zero padding k/2 (k = 1 or 3), PyTorch's
// cross-correlation. Register-tiled implicit GEMM without shared memory (slow
// on lavapipe): each invocation holds NN_CONV_CO_TILE output channels x
// NN_CONV_VOXELS voxels in vec4 accumulators; the voxels of one slot are
// consecutive across the workgroup's lanes, so input loads are contiguous, and
// the weights (packed [ci * k^3 + tap][co padded to 8], two vec4 loads per
// tap) are uniform across the workgroup.
// Tensors beyond one storage binding run as windows of batch elements, output
// and input channels (Conv3dParams); later input windows accumulate into y.
// Host module: kernels/nn/conv3d.{h,cpp}; CPU reference: kernels/nn/layers_cpu.h.
// Tests: tests/nn/test_conv3d_gpu.cpp.
#include "shared/nn_params.h"
#include "common/dispatch.glsl"

layout(local_size_x = NN_CONV_GROUP) in;
layout(push_constant) uniform Push { Conv3dParams p; };
layout(std430, binding = 0) readonly buffer In { float x_in[]; };
layout(std430, binding = 1) readonly buffer Weights { vec4 w_packed[]; };
layout(std430, binding = 2) readonly buffer Bias { float bias[]; };
layout(std430, binding = 3) buffer Out { float y_out[]; };

void main() {
  const uint g = icube_group_linear();
  const uint tile = g % p.voxel_tiles;
  const uint rest = g / p.voxel_tiles;
  const uint cob = rest % p.co_blocks;
  const uint b = rest / p.co_blocks;
  if (b >= p.batch) return;
  const uint S = p.size_x * p.size_y * p.size_z;
  const int X = int(p.size_x), Y = int(p.size_y), Z = int(p.size_z);
  const int half_k = int(p.kernel) / 2;
  const uint taps = p.kernel * p.kernel * p.kernel;

  ivec3 pos[NN_CONV_VOXELS];
  vec4 acc_lo[NN_CONV_VOXELS], acc_hi[NN_CONV_VOXELS];
  for (int k = 0; k < NN_CONV_VOXELS; ++k) {
    const uint v = tile * (NN_CONV_GROUP * NN_CONV_VOXELS) + uint(k) * NN_CONV_GROUP + gl_LocalInvocationID.x;
    const int vi = int(min(v, S - 1u));
    pos[k] = ivec3(vi / (Y * Z), (vi / Z) % Y, vi % Z);
    acc_lo[k] = vec4(0.0);
    acc_hi[k] = vec4(0.0);
  }
  for (uint cl = 0u; cl < p.ci_count; ++cl) {
    const uint ci = p.ci_begin + cl;
    const uint x_base = p.x_offset + b * p.x_batch_stride + cl * S;
    for (uint tap = 0u; tap < taps; ++tap) {
      const ivec3 off = ivec3(int(tap / (p.kernel * p.kernel)), int((tap / p.kernel) % p.kernel), int(tap % p.kernel)) - half_k;
      const uint wi = (ci * taps + tap) * p.co_vec4s + (p.co_begin / 4u) + cob * (NN_CONV_CO_TILE / 4);
      const vec4 w_lo = w_packed[wi];
      const vec4 w_hi = w_packed[wi + 1u];
      for (int k = 0; k < NN_CONV_VOXELS; ++k) {
        const ivec3 q = pos[k] + off;
        float xv = 0.0;
        if (all(greaterThanEqual(q, ivec3(0))) && q.x < X && q.y < Y && q.z < Z)
          xv = x_in[x_base + uint((q.x * Y + q.y) * Z + q.z)];
        acc_lo[k] = fma(w_lo, vec4(xv), acc_lo[k]);
        acc_hi[k] = fma(w_hi, vec4(xv), acc_hi[k]);
      }
    }
  }
  for (int k = 0; k < NN_CONV_VOXELS; ++k) {
    const uint v = tile * (NN_CONV_GROUP * NN_CONV_VOXELS) + uint(k) * NN_CONV_GROUP + gl_LocalInvocationID.x;
    if (v >= S) continue;
    for (uint c = 0u; c < NN_CONV_CO_TILE; ++c) {
      const uint cl = cob * NN_CONV_CO_TILE + c;  // channel within the window
      if (cl >= p.co_count) break;
      const float a = c < 4u ? acc_lo[k][c] : acc_hi[k][c - 4u];
      const uint yi = p.y_offset + b * p.y_batch_stride + cl * S + v;
      if (p.accumulate != 0u) y_out[yi] += a;
      else y_out[yi] = a + (p.has_bias != 0u ? bias[p.co_begin + cl] : 0.0);
    }
  }
}
