// The GSM voxel branch's Gaussian heads on the GPU (voxel_heads_reference.h's
// computation, its rows, order and traces; see voxel_branch_gpu.h for what
// runs where):
//   front    the children of the first-hit voxels (host, lexicographic) on their own grid; per child and channel
//            the masked conv features sampled at the child's centre in every view, times "this view saw the
//            parent first", maxed over the views (kernels/nn/gsm_project_features.h, from 0 when there are 30
//            views or more as the official loop), next to the parent's 3-D feature (a row gather):
//            [2-D, 3-D] -> render_head_hybrid -> vox.occ.b<i>.{ijk, head_in, head_out}
//   others   the other input voxels' 3-D features (a row gather, lexicographic) -> render_head_3D on their own
//            grid -> vox.nonocc.b<i>.* (skipped with drop_invisible)
//   head     GroupNorm -> 3x3x3 submanifold conv with fused SiLU -> 1x1 conv (OutConv)
//   decoding kernels/nn/gsm_voxel_gaussians.h: children first, then the other voxels, gaussians_per_voxel each
// The views' 3x4 projections (grid -> normalised image) are made on the host in double from the poses and
// intrinsics (the pose inverted as torch.inverse does); the kernel projects in double where the device has
// shaderFloat64, else in float32.
// Test: tests/nn/test_gsm_voxel_branch_gpu.cpp.
#pragma once

#include "nn/gsm/voxel_branch_gpu.h"

#include <array>
#include <vector>

namespace icube::nn {

struct VoxelHeadsGpuInputs {
  SparseGrid grid;                               // the input voxels
  DeviceTensor voxel_features;                   // [1, width_3d, V], rows = grid rows (the U-Net output)
  VoxelFrontMasks front;                         // front [V], front_per_view [V, N]
  DeviceTensor image_features;                   // [N, width_2d, h, w] (the conv encoder's)
  CpuTensor effective_mask;                      // [N, h, w], > 0 = effective
  std::vector<std::array<float, 16>> poses;      // [N] row-major camera-to-grid, OpenCV camera axes
  std::vector<std::array<float, 6>> intrinsics;  // [N] fx, fy, cx, cy, width, height
};

VoxelGaussiansGpu voxel_heads_gpu(VoxelBranchGpu& B, const VoxelHeadsConfig& c, const VoxelHeadsGpuInputs& in,
                                  int batch_index, VoxelBranchGpuTrace* trace);

}  // namespace icube::nn
