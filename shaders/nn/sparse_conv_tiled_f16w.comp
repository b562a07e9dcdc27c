#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv_tiled with fp16 weight storage: each row's 8 output-channel
// weights as one uvec4 of halves, decoded to fp32 in shared memory;
// accumulation stays fp32 (nn/sparse_conv_tiled.glsl).
// Host module: kernels/nn/sparse_conv.{h,cpp}. Tests: tests/nn/test_sparse_conv.cpp.
#define NN_CONV_F16_WEIGHTS 1
#include "sparse_conv_tiled.glsl"
