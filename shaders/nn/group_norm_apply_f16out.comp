#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_16bit_storage : require
// group_norm_apply with its output stored as fp16 (group_norm_apply.glsl; the
// arithmetic stays fp32, only the store rounds): the operand of the
// convolution that reads it next as R16_SFLOAT texels.
// Host module: kernels/nn/group_norm.{h,cpp} (GroupNormShape::f16_output).
// Tests: tests/nn/test_group_norm.cpp.
#define NN_NORM_F16_OUTPUT 1
#include "group_norm_apply.glsl"
