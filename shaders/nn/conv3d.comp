#version 460
#extension GL_GOOGLE_include_directive : require
// conv3d: y[b, co, v] = bias[co] + sum_{ci, tap} w[co, ci, tap] * x[b, ci, v + tap - k/2],
// dense NCDHW float32, stride 1, zero padding k/2 (k = 1 or 3), PyTorch's
// cross-correlation. Register-tiled implicit GEMM without shared memory (slow
// on lavapipe): each invocation holds NN_CONV_CO_TILE output channels x a run
// of NN_CONV_ZRUN consecutive voxels along z in vec4 accumulators. For every
// input channel and (dx, dy) it loads the run's input row once (ZRUN + k - 1
// values, zero outside the grid) and applies all k z-taps to it from registers,
// so each loaded value feeds up to k x 8 x ZRUN / (ZRUN + k - 1) FMAs; the
// weights (packed [ci * k^3 + tap][co padded to 8], two vec4 loads per tap) are
// uniform across the workgroup. Neighbouring invocations hold neighbouring
// runs, so a SIMD row's / warp's loads cover contiguous memory.
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

vec4 acc_lo[NN_CONV_ZRUN], acc_hi[NN_CONV_ZRUN];

// All K z-taps of one input row (fixed ci, dx, dy): K is a literal at both
// call sites, so the loops unroll and `row` stays in registers.
void row_taps(const int K, uint x_row, bool row_valid, int z0, int Z, uint w_row) {
  const int H = K / 2;
  float row[NN_CONV_ZRUN + 2];
  for (int j = 0; j < NN_CONV_ZRUN + K - 1; ++j) {
    const int z = z0 + j - H;
    row[j] = row_valid && z >= 0 && z < Z ? x_in[x_row + uint(z)] : 0.0;
  }
  for (int kz = 0; kz < K; ++kz) {
    const uint wi = w_row + uint(kz) * p.co_vec4s;
    const vec4 w_lo = w_packed[wi];
    const vec4 w_hi = w_packed[wi + 1u];
    for (int v = 0; v < NN_CONV_ZRUN; ++v) {
      acc_lo[v] = fma(w_lo, vec4(row[v + kz]), acc_lo[v]);
      acc_hi[v] = fma(w_hi, vec4(row[v + kz]), acc_hi[v]);
    }
  }
}

void main() {
  const uint g = icube_group_linear();
  const uint tile = g % p.voxel_tiles;
  const uint rest = g / p.voxel_tiles;
  const uint cob = rest % p.co_blocks;
  const uint b = rest / p.co_blocks;
  if (b >= p.batch) return;
  const uint S = p.size_x * p.size_y * p.size_z;
  const int X = int(p.size_x), Y = int(p.size_y), Z = int(p.size_z);
  const uint runs = (p.size_z + NN_CONV_ZRUN - 1u) / NN_CONV_ZRUN;
  const uint t_raw = tile * NN_CONV_GROUP + gl_LocalInvocationID.x;
  const bool in_grid = t_raw < p.size_x * p.size_y * runs;
  const uint t = in_grid ? t_raw : 0u;
  const int z0 = int(t % runs) * NN_CONV_ZRUN;
  const int yy = int((t / runs) % p.size_y);
  const int xx = int(t / (runs * p.size_y));
  const int K = int(p.kernel), H = K / 2;
  const uint taps = p.kernel * p.kernel * p.kernel;

  for (int v = 0; v < NN_CONV_ZRUN; ++v) {
    acc_lo[v] = vec4(0.0);
    acc_hi[v] = vec4(0.0);
  }
  const uint co_vec = p.co_begin / 4u + cob * (NN_CONV_CO_TILE / 4);
  for (uint cl = 0u; cl < p.ci_count; ++cl) {
    const uint ci = p.ci_begin + cl;
    const uint x_base = p.x_offset + b * p.x_batch_stride + cl * S;
    for (int dx = 0; dx < K; ++dx) {
      const int qx = xx + dx - H;
      for (int dy = 0; dy < K; ++dy) {
        const int qy = yy + dy - H;
        const bool row_valid = qx >= 0 && qx < X && qy >= 0 && qy < Y;
        const uint x_row = x_base + uint(clamp(qx, 0, X - 1) * Y + clamp(qy, 0, Y - 1)) * uint(Z);
        const uint w_row = (ci * taps + uint((dx * K + dy) * K)) * p.co_vec4s + co_vec;
        if (K == 3) row_taps(3, x_row, row_valid, z0, Z, w_row);
        else row_taps(1, x_row, row_valid, z0, Z, w_row);
      }
    }
  }
  if (!in_grid) return;
  const uint v0 = uint((xx * Y + yy) * Z + z0);
  for (int v = 0; v < NN_CONV_ZRUN; ++v) {
    if (z0 + v >= Z) break;
    for (uint c = 0u; c < NN_CONV_CO_TILE; ++c) {
      const uint cl = cob * NN_CONV_CO_TILE + c;  // channel within the window
      if (cl >= p.co_count) break;
      const float a = c < 4u ? acc_lo[v][c] : acc_hi[v][c - 4u];
      const uint yi = p.y_offset + b * p.y_batch_stride + cl * S + v0 + uint(v);
      if (p.accumulate != 0u) y_out[yi] += a;
      else y_out[yi] = a + (p.has_bias != 0u ? bias[p.co_begin + cl] : 0.0);
    }
  }
}
