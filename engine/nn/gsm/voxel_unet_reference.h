// The GSM voxel branch up to its per-voxel features (InfiniCube Pure3DUnet with
// its Lifter, gsm_small README step 5 up to vox.out.b<i>) as a plain CPU
// reference, one batch element at a time:
//   lifter      each effective pixel gives its image feature to the first voxel its ray enters; a voxel
//               holds the mean of what it received (0 if nothing) -> vox.lifter.in; a linear layer
//               (lifter.mix_fc) -> vox.lifter
//   hash tree   level d (1 .. num_blocks-1): voxel size vs 2^d, origin origin + vs (2^d - 1) / 2, holding
//               for every input voxel centre the 8 level-d voxels around it (fvdb
//               gridbatch_from_nearest_voxels_to_points); level 0 = the input grid
//   encoder     pre_conv (1x1x1) -> vox.pre_conv; per level d: (d > 0) 2x2x2 max pooling onto the level's grid
//               over the existing children (none: 0), then a residual block -> vox.encoders.Enc<d>.0
//   block       h = ConvBlock2(ConvBlock1(x)), y = h + skip(x); ConvBlock = GroupNorm (num_groups, 1 when the
//               width is smaller) -> 3x3x3 submanifold conv without bias -> SiLU; skip = identity, or a 1x1x1
//               conv with bias when the width changes; encoder blocks widen in conv2 (conv1 to
//               max(out / 2, in))
//   bottleneck  pre_kl_bottleneck_0, post_kl_bottleneck_0, post_kl_bottleneck_1 on the coarsest level
//               (neck_dense_type UNCHANGED)
//   decoder     level by level upward: every voxel of the current grid that is in the hash tree's grid of
//               its level is subdivided by 2 (features copied), the encoder features of the same voxels are
//               put in front ([encoder (0 where absent), upsampled]) and a block runs ->
//               vox.decoders.Dec-<k>.0 (k = num_blocks - level); finally only the input voxels are kept ->
//               vox.out.b<i>
//   front       vox.occ_front_mask.b<i> [V] and vox.occ_front_per_camera.b<i> [V, N]: voxels that are some
//               view's (that view's) first hit
// The struct_convs (structure heads) are not run: the hash tree decides the structure. Sparse 3x3x3 weights
// are fVDB 0.2.0's (reversed kernel axes, converted with fvdb020_kernel_to_grid_order). Rows: level-0
// tensors follow the input grid's rows, the other levels are in lexicographic ijk order; traces of batch
// element b > 0 get the suffix ".b<b>" (the `.b<i>` names use their own), each sparse tensor also as
// `<name>.ijk`. Weights `backbone.backbone_3d.*`. Test: tests/nn/test_gsm_voxel_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/sparse_cpu.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <vector>

namespace icube::nn {

struct VoxelUnetConfig {
  int image_channels = 0;  // lifter_params.img_in_dim: the image features' width
  int in_channels = 0;     // in_channels (= lifter_params.voxel_out_dim)
  int num_blocks = 0;      // levels
  int f_maps = 0;          // level 0's width; level d has f_maps 2^d
  int num_groups = 8;      // GroupNorm groups
  // n_features: in_channels, then f_maps * 2^d per level.
  std::vector<int> widths() const;
};

// From config.json's hparams.backbone.params.backbone_3d_params (`hparams` = the whole hparams object), with
// the Pure3DUnet defaults for what it omits; settings this reference does not implement (another block order,
// attention, a dense neck, non-residual blocks) are a scene::InputError naming the key.
VoxelUnetConfig voxel_unet_config_from_json(const nlohmann::json& hparams);

// The lifter: the mean, then lifter.mix_fc -> [voxels, in_channels] (traces vox.lifter.in, vox.lifter).
CpuTensor voxel_lifter_forward(const VoxelUnetConfig& c, const GsmWeights& w, const CpuTensor& image_features,
                               const std::vector<int32_t>& first_voxel, const CpuTensor& effective_mask, int64_t voxels,
                               int batch_index, GsmTrace* trace);

// The sparse U-Net on the input grid: lifted [V, in_channels] -> [V, f_maps], rows = grid rows.
CpuTensor voxel_unet_forward(const VoxelUnetConfig& c, const GsmWeights& w, const SparseGrid& grid,
                             const CpuTensor& lifted, int batch_index, GsmTrace* trace);

// Level d of the hash tree: for every input voxel centre the 8 level-d voxels around it, lexicographic; voxel
// size vs 2^d, origin origin + vs (2^d - 1) / 2. The centre of voxel v is at (v + 1/2) vs on its axis; in
// level-d voxel units (v + 1/2) / 2^d - 1/2, whose floor is floor((2v + 1 - 2^d) / 2^(d+1)); the 8 voxels are
// that floor and the next one per axis. Exact in integers: the fraction is never 0.
SparseGrid gsm_hash_tree_level(const SparseGrid& input, int d);

struct VoxelFrontMasks {
  std::vector<uint8_t> front;           // [V]: first hit of some view
  std::vector<uint8_t> front_per_view;  // [V, N]: first hit of view n
};

// From the first-hit rows [N * H * W] of N views (traced as vox.occ_front_mask.b<i>, vox.occ_front_per_camera.b<i>).
VoxelFrontMasks voxel_front_masks(const std::vector<int32_t>& first_voxel, int64_t views, int64_t voxels,
                                  int batch_index, GsmTrace* trace);

struct VoxelBranchFeatures {
  CpuTensor features;  // [V, f_maps], rows = the input grid's rows (vox.out.b<i>)
  VoxelFrontMasks front;
};

// Lifter, U-Net and front masks of one batch element.
VoxelBranchFeatures voxel_branch_features(const VoxelUnetConfig& c, const GsmWeights& w, const SparseGrid& grid,
                                          const CpuTensor& image_features, const std::vector<int32_t>& first_voxel,
                                          const CpuTensor& effective_mask, int batch_index, GsmTrace* trace);

}  // namespace icube::nn
