#version 460
#extension GL_GOOGLE_include_directive : require
// conv3d_coopmat: conv3d (nn/conv3d.comp's convolution) as an implicit GEMM on
// NVIDIA's tensor cores through GL_NV_cooperative_matrix: a 64 x 64 block of
// (voxels x output channels) per workgroup of 4 subgroups, each multiplying
// 2 x 2 fragments of 16 x 16 x 16 fp16 with fp32 accumulators. Each K step of
// 32 (input channels x taps) is gathered from the input texel buffer and the
// packed weights into fp16 shared tiles (the next step's global loads in
// flight during the multiplies), the result staged through shared memory so
// every thread writes consecutive voxels of one channel. Inputs are rounded to
// fp16 (|x| > 65504 overflows, as in PyTorch's half precision): the network
// uses this kernel when it runs with fp16 weights.
// The GEMM core is nn/gemm_coopmat.glsl (shared with sparse_conv_coopmat).
// Host module: kernels/nn/conv3d.{h,cpp} (Conv3dPath::kCoopMatrix, requires
// DeviceInfo::cooperative_matrix_nv and subgroups of 32). The tiling is tested on
// lavapipe through nn/conv3d_coopmat_emulated.comp (same body, fragments
// emulated per lane); the real fragments by tools/device-check.sh.
// Tests: tests/nn/test_conv3d.cpp.
#define NN_COOPMAT_NV 1
#include "conv3d_coopmat.glsl"
