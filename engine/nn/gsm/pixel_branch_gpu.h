// The GSM's pixel branch on the GPU: the computation of pixel_branch_reference.h
// through the LayerRecorder —
//   UNet input   [RGB, the depth priors, the DAV2 feature] by channel concatenation: "voxel_depth" as
//                is, "masked_voxel_depth" with the 16x16 patches of the random draw zeroed (a channel
//                affine over the depth viewed as [1, V * H * W / P, P]: one 0 / 1 scale per patch-row
//                run of P pixels, written in command order), the DAV2 feature resized bilinearly
//                (align_corners false) to H x W; maps of another size are resized bilinearly first
//   x-unet       xunet_gpu.h
//   linear_out   a per-pixel linear layer as a 1x1 convolution over tokens -> [V, G * D, H * W]
//   decoding     kernels/nn/gsm_pixel_gaussians.h: every pixel's G Gaussians densely
//                [V, H * W * G, D + 2] (mean 3, scale 3, rotation 4, opacity 1, colour D - 9) and
//                its keep value (fg - fg * grid_fg with the voxel branch, else fg)
//   compaction   on the host after download (compact_pixel_gaussians): the kept pixels' Gaussians in
//                (view, row, column, which) order, per batch element — an ordered copy
// (G = gs_per_pixel, D = gs_dim.) Weights: backbone.backbone_2d.net.* in add_xunet_gpu_tensors' forms and
// backbone.backbone_2d.linear_out.*, from the GSM's GPU store (gsm_gpu_weights.h).
// Test: tests/nn/test_gsm_pixel_branch_gpu.cpp (pix.*, gs.b0.pixel.* of gsm_small; two views against
// the CPU reference).
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/device_tensor.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/pixel_branch_reference.h"
#include "nn/layer_recorder.h"

#include <map>
#include <string>
#include <vector>

namespace icube::nn {

// Throws scene::InputError naming `source` for a setting the GPU branch does not implement (check_xunet_gpu).
void check_pixel_branch_gpu(const PixelBranchConfig& c, const std::string& source);

// The branch's device inputs (V = B * N views, view-major within a batch element).
struct PixelBranchGpuInputs {
  DeviceTensor images;           // [V, 3, H, W] RGB in [0, 1]
  DeviceTensor voxel_depth;      // [V, 1, h, w] (pix.voxel_depth)
  DeviceTensor grid_foreground;  // [V, 1, H, W] 1 where the pixel's ray meets the grid (pre.grid_fg_mask), else 0
  DeviceTensor foreground;       // [V, 1, H, W] segmentation foreground (mask ch0) as 0 / 1 (pixel_branch_foreground)
  DeviceTensor dav2_feature;     // [V, C, h', w'] (enc.dav2.out)
};

struct PixelBranchGpuOutput {
  DeviceTensor gaussians;  // [V, H * W * G, D + 2]: every pixel's Gaussians, decoded
  DeviceTensor mask;       // [V, 1, H, W]: the keep value (pix.gaussian_pixel_mask); kept where > 0
};

// What the branch recorded, under the reference's names in the GPU layouts: pix.masked_voxel_depth
// [V, 1, H, W], pix.unet_in, pix.unet.<block> [V, C, h, w], pix.unet_out, pix.gs_params [V, G * D, H * W]
// (channel-major), pix.gaussian_pixel_mask [V, 1, H, W]. download_pixel_branch_trace converts them.
struct PixelBranchGpuTrace {
  std::map<std::string, DeviceTensor> tensors;
};

// The segmentation foreground (mask ch0) as [V, 1, H, W] of 0 / 1, for PixelBranchGpuInputs::foreground.
CpuTensor pixel_branch_foreground(const GsmInputs& in);

// Records the branch on L (between L.begin and L.end). `in` gives the batch and view counts, the image
// size, the depth-patch draw (depth_patch_keep), the poses and the intrinsics (whose width and height
// must be the image's: scene::InputError); std::invalid_argument for device inputs of the wrong shape.
PixelBranchGpuOutput pixel_branch_gpu(LayerRecorder& L, const PixelBranchConfig& c, const GsmInputs& in,
                                      const PixelBranchGpuInputs& x, PixelBranchGpuTrace* trace = nullptr);

// The kept pixels' Gaussians per batch element, in (view, row, column, which) order, from the dense
// decoding (gaussians [V * H * W * G * (D + 2)], mask [V * H * W]).
std::vector<PixelGaussians> compact_pixel_gaussians(const PixelBranchConfig& c, int64_t batch, int64_t views, int64_t height,
                                                    int64_t width, const std::vector<float>& gaussians,
                                                    const std::vector<float>& mask);

// Downloads a recorded branch's output (after the submission completed) and compacts it.
std::vector<PixelGaussians> download_pixel_gaussians(gpu::Context& ctx, const PixelBranchConfig& c, const GsmInputs& in,
                                                     const PixelBranchGpuOutput& out);

// Downloads a trace into the reference's names and layouts: pix.unet.<block> [V, C, 1, h, w], pix.gs_params
// [B, N, H, W, G * D], pix.gaussian_pixel_mask [B, N, H, W], the others as recorded.
GsmTrace download_pixel_branch_trace(gpu::Context& ctx, const GsmInputs& in, const PixelBranchGpuTrace& trace);

}  // namespace icube::nn
