#version 460
#extension GL_GOOGLE_include_directive : require
// sparse_conv_tiled: the submanifold 3^3 convolution as a gathered implicit
// GEMM for GPUs (the body and its description: nn/sparse_conv_tiled.glsl),
// fp32 weights.
// Host module: kernels/nn/sparse_conv.{h,cpp} (Conv3dPath::kSharedTile);
// CPU reference: nn::cpu::conv3d on SparseTensor. Tests: tests/nn/test_sparse_conv.cpp.
#include "sparse_conv_tiled.glsl"
