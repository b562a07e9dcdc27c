#version 460
#extension GL_GOOGLE_include_directive : require
// conv3d_tiled: y[b, co, v] = bias[co] + sum_{ci, tap} w[co, ci, tap] * x[b, ci, v + tap - k/2],
// the same convolution as nn/conv3d.comp, for discrete GPUs: an implicit GEMM
// (M = voxels, N = output channels, K = input channels x k^3) with a 64 x 64
// block tile per workgroup of 256 threads staged through shared memory in
// double-buffered K steps of 16 (one barrier per step; the next step's global
// loads are issued before the current step's FMAs), each thread a 4 x 4
// register micro-tile read as vec4s from shared memory. A is gathered from the
// input texel buffer per (voxel, input channel, tap) with zero padding; B is
// the packed weight rows [ci * k^3 + tap][co padded to 8], read as vec4s.
// Windows, offsets and accumulation are conv3d's (Conv3dParams).
// Host module: kernels/nn/conv3d.{h,cpp} (Conv3dPath::kSharedTile); CPU
// reference: nn::cpu::conv3d. Tests: tests/nn/test_conv3d.cpp.
#include "conv3d_tiled.glsl"
