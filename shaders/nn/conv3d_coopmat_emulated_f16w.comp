#version 460
#extension GL_GOOGLE_include_directive : require
// nn/conv3d_coopmat_emulated.comp with fp16 weight storage.
// Host module: kernels/nn/conv3d.{h,cpp}. Tests: tests/nn/test_conv3d.cpp.
#define NN_CONV_F16_WEIGHTS 1
#include "conv3d_coopmat.glsl"
