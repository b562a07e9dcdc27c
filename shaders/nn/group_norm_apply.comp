#version 460
#extension GL_GOOGLE_include_directive : require
// group_norm_apply: pass 3 of GroupNorm (see group_norm_apply.glsl), fp32 output.
// Host module: kernels/nn/group_norm.{h,cpp}. Tests: tests/nn/test_group_norm.cpp.
#include "group_norm_apply.glsl"
