#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_float64 : require
// gsm_project_features_f64: the projected-feature sampling and maximum over
// the views with the sample point's projection in double (needs
// shaderFloat64); see gsm_project_features.glsl. Host module:
// kernels/nn/gsm_project_features.{h,cpp}. Tests: tests/nn/test_gsm_project_features.cpp.
#define GSM_PROJECT_F64 1
#include "nn/gsm_project_features.glsl"
