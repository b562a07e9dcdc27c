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
// runs, so a SIMD row's / warp's loads cover contiguous memory. The input is
// read as an R32_SFLOAT texel buffer: on lavapipe a texel fetch is one
// hardware gather, a storage-buffer load at a per-lane address a loop over the
// lanes (18.4 against 17.3 GFLOP/s at C192 16^3, 13.3 against 10.6 at C384 32^3).
// Tensors beyond one storage binding run as windows of batch elements, output
// and input channels (Conv3dParams); later input windows accumulate into y.
// Host module: kernels/nn/conv3d.{h,cpp}; CPU reference: nn::cpu::conv3d (kernels/nn/conv3d.h).
// nn/conv3d_f16w.comp is the same kernel with the weights stored as fp16
// (8 halves per tap and channel block, fp32 accumulation).
// Tests: tests/nn/test_conv3d.cpp.
#include "conv3d.glsl"
