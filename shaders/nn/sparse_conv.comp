#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv: the submanifold 3^3 convolution of a sparse voxel tensor over
// its kernel map, lavapipe's register tile (the body and its description:
// nn/sparse_conv.glsl), fp32 weights.
// Host module: kernels/nn/sparse_conv.{h,cpp}. CPU reference: nn::cpu::conv3d
// on SparseTensor (kernels/nn/sparse_cpu.h). Tests: tests/nn/test_sparse_conv.cpp.
#include "sparse_conv.glsl"
