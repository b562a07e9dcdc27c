#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv_coopmat: the submanifold 3^3 convolution as a gathered implicit
// GEMM on NVIDIA's tensor cores (GL_NV_cooperative_matrix; the body and its
// description: nn/sparse_conv_coopmat.glsl), fp32 weights rounded to fp16 in
// the shared tiles. Inputs are rounded to fp16 (|x| > 65504 overflows).
// Host module: kernels/nn/sparse_conv.{h,cpp} (Conv3dPath::kCoopMatrix, requires
// DeviceInfo::cooperative_matrix_nv and subgroups of 32); the real fragments are
// tested by tools/device-check.sh. Tests: tests/nn/test_sparse_conv.cpp.
#define NN_COOPMAT_NV 1
#include "sparse_conv_coopmat.glsl"
