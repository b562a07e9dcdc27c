#version 460
#extension GL_GOOGLE_include_directive : require
// conv3d_tiled with fp16 weight storage: nn/conv3d_tiled.comp's kernel (see
// its header) reading each row's 8 output-channel weights as one uvec4 of
// halves, decoded to fp32 in shared memory; accumulation stays fp32.
// Host module: kernels/nn/conv3d.{h,cpp}. Tests: tests/nn/test_conv3d.cpp.
#define NN_CONV_F16_WEIGHTS 1
#include "conv3d_tiled.glsl"
