#version 460
#extension GL_GOOGLE_include_directive : require
// gsm_project_features: the projected-feature sampling and maximum over the
// views with the projection in float32 (devices without shaderFloat64); see
// gsm_project_features.glsl. Host module: kernels/nn/gsm_project_features.{h,cpp}.
// Tests: tests/nn/test_gsm_project_features.cpp.
#include "nn/gsm_project_features.glsl"
