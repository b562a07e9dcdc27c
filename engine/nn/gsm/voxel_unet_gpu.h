// The GSM voxel branch's lifter and hash-tree-guided sparse U-Net on the GPU
// (voxel_unet_reference.h's computation, the rows and traces it has; see
// voxel_branch_gpu.h for what runs where):
//   lifter   the effective pixels' features grouped per first-hit voxel on the host (deterministic lists),
//            averaged by kernels/nn/scatter_mean.h into [V, C], turned channel-major by a row gather, then
//            lifter.mix_fc (a 1x1 conv) -> vox.lifter.in, vox.lifter
//   U-Net    pre_conv; per level: max pooling onto the hash tree's grid (existing children, 0 where none),
//            a residual block (GroupNorm -> submanifold conv with fused SiLU, twice; identity or 1x1 skip);
//            the kl bottlenecks; decoding: the voxels of the tree's next-finer level subdivided (parent rows
//            gathered), the encoder features of the same voxels gathered in front (0 where absent), a
//            block; the input voxels gathered last -> vox.out.b<i>
// Level grids and row tables are built on the host in lexicographic order (the reference's); each level's
// kernel map on the GPU. Test: tests/nn/test_gsm_voxel_branch_gpu.cpp.
#pragma once

#include "nn/gsm/voxel_branch_gpu.h"

namespace icube::nn {

// image_features [N, image_channels, H, W] on the device, first_voxel [N * H * W] (row or -1), effective_mask
// [N, H, W] (> 0 = effective) -> [1, in_channels, voxels] (traces vox.lifter.in, vox.lifter).
DeviceTensor voxel_lifter_gpu(VoxelBranchGpu& B, const VoxelUnetConfig& c, const DeviceTensor& image_features,
                              const std::vector<int32_t>& first_voxel, const CpuTensor& effective_mask, int64_t voxels,
                              int batch_index, VoxelBranchGpuTrace* trace);

// lifted [1, in_channels, V] on `grid` (kernel map built) -> [1, f_maps, V] on the grid's rows.
DeviceTensor voxel_unet_gpu(VoxelBranchGpu& B, const VoxelUnetConfig& c, const VoxelGridGpu& grid, const DeviceTensor& lifted,
                            int batch_index, VoxelBranchGpuTrace* trace);

}  // namespace icube::nn
