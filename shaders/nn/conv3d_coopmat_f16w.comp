#version 460
#extension GL_GOOGLE_include_directive : require
// conv3d_coopmat with fp16 weight storage (8 halves per uvec4 row vector,
// copied to the shared B tile without conversion); see nn/conv3d_coopmat.comp.
// Host module: kernels/nn/conv3d.{h,cpp}. Tests: tests/nn/test_conv3d.cpp.
#define NN_COOPMAT_NV 1
#define NN_CONV_F16_WEIGHTS 1
#include "conv3d_coopmat.glsl"
