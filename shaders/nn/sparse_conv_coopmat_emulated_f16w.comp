#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv_coopmat_emulated with fp16 weight storage; see
// nn/sparse_conv_coopmat_emulated.comp and nn/sparse_conv_coopmat_f16w.comp.
// Host module: kernels/nn/sparse_conv.{h,cpp}. Tests: tests/nn/test_sparse_conv.cpp.
#define NN_CONV_F16_WEIGHTS 1
#include "sparse_conv_coopmat.glsl"
