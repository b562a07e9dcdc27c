#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv_coopmat's tiling without cooperative matrices: the same body with
// each 16 x 16 fragment load, multiply-add and store written out per lane of a
// 32-invocation group (nn/gemm_coopmat.glsl). Slow; it exists so lavapipe tests
// the cooperative-matrix kernel's tiles, offsets, strides and windows.
// Host module: kernels/nn/sparse_conv.{h,cpp} (Conv3dPath::kCoopMatrixEmulated).
// Tests: tests/nn/test_sparse_conv.cpp.
#include "sparse_conv_coopmat.glsl"
