// The GSM voxel branch's Gaussian heads (InfiniCube Pure3DUnet.decode after the
// U-Net, gsm_small README step 5 from "Voxels that are some view's first hit"
// and step 7's voxel outputs) as a plain CPU reference:
//   - the input voxels that are some view's first hit ("front") are split into
//     occ_upsample^3 children; each child's centre is projected into every view
//     and the effective-masked image features are sampled as F.grid_sample does
//     (bilinear, zeros outside, align_corners=False: pixel centres at +0.5),
//     multiplied by "this view saw the parent first" and maxed over the views
//     (the masked views take part with 0; from 30 views on the official loop
//     starts from 0, so the maximum is never negative); [2-D, copied 3-D
//     feature] goes through render_head_hybrid on the children grid;
//   - the other input voxels go through render_head_3D on a grid of only them;
//   - each head is GroupNorm -> 3x3x3 submanifold conv (its own grid's
//     neighbours) -> SiLU -> 1x1 conv giving gsplat_upsample x 14 raw values per
//     voxel, decoded (gs_free_space "hard") as mean = voxel min corner +
//     sigmoid(xyz) * voxel size, scale = min(exp(raw) * voxel size, max_scaling),
//     rotation = quaternion / norm, opacity = sigmoid, colour raw.
// Output order: children sorted by ijk, then the other voxels sorted by ijk,
// gsplat_upsample consecutive Gaussians each. Traces vox.occ.b<i>.{ijk,head_in,
// head_out} and vox.nonocc.b<i>.{ijk,head_in,head_out}.
// Test: tests/nn/test_gsm_voxel_heads_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/sparse_cpu.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"

#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace icube::nn {

struct VoxelHeadsConfig {
  int width_3d = 0;             // f_maps: the U-Net's output width (n_features[1])
  int width_2d = 0;             // f_maps_2d: the image features' width
  int gaussians_per_voxel = 1;  // gsplat_upsample
  int gs_dim = 14;              // xyz 3, scale 3, rotation 4, opacity 1, colour gs_dim - 11
  int occ_upsample = 2;         // children per axis of a front voxel
  double max_scaling = 0.0;     // scales clamped to it when > 0
  int num_groups = 8;           // GroupNorm groups (1 when the width is smaller)
  bool drop_invisible = false;  // true: no Gaussians for the non-front voxels
};

// From config.json's hparams.backbone.params.backbone_3d_params (`hparams` = the whole hparams object), with the
// Pure3DUnet defaults for what it omits; throws scene::InputError for settings this reference does not implement.
VoxelHeadsConfig voxel_heads_config_from_json(const nlohmann::json& hparams);

// One batch element's inputs.
struct VoxelHeadsInputs {
  SparseGrid grid;                       // the input voxels (released: 0.2 m, origin 0.1 m)
  CpuTensor voxel_features;              // [V, width_3d], rows = grid rows (the U-Net output)
  std::vector<uint8_t> front;            // [V]: first hit of some view
  std::vector<uint8_t> front_per_view;   // [V, N]: first hit of view n
  CpuTensor image_features;              // [N, width_2d, h, w] (the conv encoder's)
  CpuTensor effective_mask;              // [N, h, w] at the features' resolution, > 0 = effective
  std::vector<std::array<float, 16>> poses;      // [N] row-major camera-to-grid, OpenCV camera axes
  std::vector<std::array<float, 6>> intrinsics;  // [N] fx, fy, cx, cy, width, height
};

// The voxel Gaussians of one batch element, n of them.
struct VoxelGaussians {
  CpuTensor means, scales, rotations, opacities, colors;  // [n, 3], [n, 3], [n, 4], [n, 1], [n, gs_dim - 11]
  std::vector<int32_t> src_ijk;    // [n, 3]: the source voxel's ijk (at its level's voxel size)
  std::vector<int32_t> src_level;  // [n]: 0 = a child of a front voxel, 1 = another input voxel
  std::vector<int32_t> src_sub;    // [n]: which of the voxel's Gaussians
  int64_t count() const { return static_cast<int64_t>(src_level.size()); }
};

// Per view, the 3x4 matrix from grid coordinates to (u w, v w, w) with u, v normalised by the image size
// (camera_intrinsic_list_to_matrix(normalize_pixel=True) times torch.inverse(pose)[:3]): the general 4x4
// inverse (Gauss-Jordan with partial pivoting) in double; a singular pose is a scene::InputError.
std::vector<std::array<double, 12>> gsm_world_to_normalized_image(const std::vector<std::array<float, 16>>& poses,
                                                                 const std::vector<std::array<float, 6>>& intrinsics);

VoxelGaussians voxel_heads_forward(const VoxelHeadsConfig& c, const GsmWeights& w, const VoxelHeadsInputs& in,
                                   int batch_index, GsmTrace* trace);

}  // namespace icube::nn
