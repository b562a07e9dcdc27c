#version 460
#extension GL_GOOGLE_include_directive : require
// conv3d with fp16 weight storage: shaders/nn/conv3d.comp's kernel (see its
// header) reading each tap's 8 output-channel weights as one uvec4 of halves;
// inputs, outputs and accumulation stay fp32.
// Host module: kernels/nn/conv3d.{h,cpp} (Conv3dShape::f16_weights).
// Tests: tests/nn/test_conv3d.cpp.
#define NN_CONV_F16_WEIGHTS 1
#include "conv3d.glsl"
