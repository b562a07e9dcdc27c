#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv_coopmat with fp16 weight storage (8 halves per uvec4 row vector,
// copied to the shared B tile without conversion); see nn/sparse_conv_coopmat.comp.
// Host module: kernels/nn/sparse_conv.{h,cpp}. Tests: tests/nn/test_sparse_conv.cpp.
#define NN_COOPMAT_NV 1
#define NN_CONV_F16_WEIGHTS 1
#include "sparse_conv_coopmat.glsl"
