// The GSM's pixel branch (InfiniCube Pure2DUNet, voxelgen/modules/gsm_modules/
// backbone/pixel_branch.py; gsm_small README step 6) as a plain CPU reference:
//   UNet input, per view: [RGB in [0, 1], the depth priors, the DAV2 feature]
//   where the priors come in the official order whatever concat_depth_priors'
//   order: "voxel_depth" (as is), "masked_voxel_depth" (16x16 patches zeroed
//   by the random draw, here GsmInputs::depth_patch_keep), then "dav2_feature"
//   (bilinear, half-pixel centres, resized to H x W); maps of another size are
//   resized bilinearly (align_corners false) first.
//   x-unet (xunet_reference.h) -> per-pixel linear_out -> gs_per_pixel x gs_dim
//   raw values (depth 1, scale 3, rotation 4, opacity 1, colour gs_dim - 9).
//   Decoding: ray through the integer pixel (u, v): ((u - cx) / fx, (v - cy) / fy, 1)
//   taken to the grid by the camera-to-grid pose (as the official
//   (P [x, 1])[:3] - t in float32) and normalised; depth = sigmoid(raw) (zfar -
//   znear) + znear ("weight"; "inverse_metric_depth": 1 / sigmoid(raw)),
//   distance = depth / <camera z axis, ray>, mean = camera centre + distance ray;
//   scale = min(exp(raw - 2.3), max_scale); opacity = sigmoid(raw - 1);
//   rotation / its norm; colour raw.
//   Kept pixels: with the voxel branch (DualBranchUNet at inference, use_3d)
//   the mid-ground, fg - fg * grid_fg > 0 (fg = segmentation foreground, mask
//   ch0; grid_fg = the grid-foreground mask); without it every fg pixel.
//   Gaussians in (view, row, column, which) order.
// Weights backbone.backbone_2d.net.* (the x-unet) and backbone.backbone_2d.linear_out.*.
// Test: tests/nn/test_gsm_pixel_branch_reference.cpp (pix.*, gs.b0.pixel.* of gsm_small).
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"
#include "nn/gsm/xunet_reference.h"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <vector>

namespace icube::nn {

struct PixelBranchConfig {
  XUnetConfig unet;
  bool voxel_depth_prior = false;         // "voxel_depth" in concat_depth_priors
  bool masked_voxel_depth_prior = false;  // "masked_voxel_depth"
  bool dav2_feature_prior = false;        // "dav2_feature"
  int depth_patch_size = 16;              // masked_voxel_depth_params.patch_size
  int gs_per_pixel = 0, gs_dim = 0;       // gs_dim >= 9: depth, scale 3, rotation 4, opacity, colour gs_dim - 9
  double znear = 0.0, zfar = 0.0, max_scale = 0.0;
  bool inverse_metric_depth = false;  // interpret_output_depth: false = "weight"
  bool midground_only = true;         // hparams.backbone.params.use_3d: keep fg pixels the grid does not cover

  int64_t unet_input_channels(int64_t dav2_channels) const {
    return 3 + (voxel_depth_prior ? 1 : 0) + (masked_voxel_depth_prior ? 1 : 0) + (dav2_feature_prior ? dav2_channels : 0);
  }
};

// From config.json's hparams (`hparams` = the whole hparams object): backbone.params.backbone_2d_params and
// backbone.params.use_3d (absent: false, the pixel branch alone).
// Throws scene::InputError for a missing or malformed value, std::invalid_argument for an unsupported
// option (feature_source other than "original_rgb", "provided_depth").
PixelBranchConfig pixel_branch_config_from_json(const nlohmann::json& hparams);

// One batch element's pixel Gaussians, n of them.
struct PixelGaussians {
  CpuTensor means;      // [n, 3] grid frame
  CpuTensor scales;     // [n, 3]
  CpuTensor rotations;  // [n, 4] unit quaternions in the raw order
  CpuTensor opacities;  // [n, 1]
  CpuTensor colors;     // [n, gs_dim - 9]
  std::vector<int32_t> src;  // [n, 4]: view (within the batch element), row, column, which Gaussian of the pixel

  int64_t count() const { return means.shape.empty() ? 0 : means.dim(0); }
};

// The UNet input [V, C, H, W] (V = B * N, view-major within a batch element). voxel_depth [V, 1, h, w];
// dav2_feature [V, C_dav2, h', w']. Traces pix.masked_voxel_depth [V, 1, H, W] and pix.unet_in.
CpuTensor pixel_branch_unet_input(const PixelBranchConfig& config, const GsmInputs& inputs, const CpuTensor& voxel_depth,
                                  const CpuTensor& dav2_feature, GsmTrace* trace);

// Decodes gs_params [B, N, H, W, gs_per_pixel * gs_dim] into each batch element's kept pixels'
// Gaussians. grid_fg_mask [V * H * W] (uint8, 1 = the pixel's ray meets the grid). Traces
// pix.gaussian_pixel_mask [B, N, H, W].
std::vector<PixelGaussians> decode_pixel_gaussians(const PixelBranchConfig& config, const GsmInputs& inputs,
                                                   const CpuTensor& gs_params, const std::vector<uint8_t>& grid_fg_mask,
                                                   GsmTrace* trace);

// The whole branch: input, x-unet, linear_out (traces pix.unet_out [V, out_dim, H, W], pix.gs_params
// [B, N, H, W, gs_per_pixel * gs_dim]) and decoding. Returns one PixelGaussians per batch element.
std::vector<PixelGaussians> pixel_branch_forward(const PixelBranchConfig& config, const GsmWeights& weights,
                                                 const GsmInputs& inputs, const CpuTensor& voxel_depth,
                                                 const std::vector<uint8_t>& grid_fg_mask, const CpuTensor& dav2_feature,
                                                 GsmTrace* trace);

}  // namespace icube::nn
