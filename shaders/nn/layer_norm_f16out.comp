#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_16bit_storage : require
// layer_norm with its output stored as fp16 (layer_norm.glsl; the statistics
// and arithmetic stay fp32, only the store rounds): the operand of the linear
// (a 1x1 convolution) that reads it next as R16_SFLOAT texels.
// Host module: kernels/nn/layer_norm.{h,cpp} (LayerNormShape::f16_output).
// Tests: tests/nn/test_layer_norm.cpp.
#define NN_NORM_F16_OUTPUT 1
#include "layer_norm.glsl"
