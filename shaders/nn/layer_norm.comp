#version 460
#extension GL_GOOGLE_include_directive : require
// layer_norm over channels with an fp32 output (see layer_norm.glsl).
// Host module: kernels/nn/layer_norm.{h,cpp}. Tests: tests/nn/test_layer_norm.cpp.
#include "layer_norm.glsl"
