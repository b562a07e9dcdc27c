#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv with fp16 weight storage: nn/sparse_conv.glsl's register tile
// reading each tap's 8 output-channel weights as one uvec4 of halves; inputs,
// outputs and accumulation stay fp32.
// Host module: kernels/nn/sparse_conv.{h,cpp} (SparseConvShape::f16_weights).
// Tests: tests/nn/test_sparse_conv.cpp.
#define NN_CONV_F16_WEIGHTS 1
#include "sparse_conv.glsl"
