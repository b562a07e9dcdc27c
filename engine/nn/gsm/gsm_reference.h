// InfiniCube's stage-3 feed-forward reconstruction model (the GSM,
// voxelgen/models/gsm.py with the released dual-branch configuration) as one
// plain CPU reference, composed of its stages in the official order:
//   1. masks: sky = segmentation ch0 == 0; effective = ch1 && ch2
//   2. image features: the conv encoder (conv_encoder_reference.h) and Depth-Anything-V2 (dav2_reference.h)
//   3. the sky token (sky_reference.h)
//   4. pixel rays through each batch element's voxels (gsm_rays.h): first hits, the grid-foreground mask
//      (the official mask ch3), the voxel depth
//   5. the voxel branch: lifter and sparse U-Net (voxel_unet_reference.h), then the 0.1 m split of first-hit
//      voxels and the Gaussian heads (voxel_heads_reference.h)
//   6. the pixel branch (pixel_branch_reference.h): x-unet on [RGB, masked voxel depth, DAV2 feature],
//      2 Gaussians per mid-ground pixel
//   7. the sky's colour behind every input pixel and on a 256 x 512 panorama
// The configuration is a case's config.json (`hparams` under the official names, `dav2_config`: the form of
// ../shared/data/models/gsm_small/config.json and of tools/convert_checkpoint.py's gsm_config.json).
// Outputs and intermediates carry the reference case's names (gsm_output_tensors, GsmTrace), so a user can
// find the first stage that differs from PyTorch. Test: tests/nn/test_gsm_forward_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/gsm/conv_encoder_reference.h"
#include "nn/gsm/dav2_reference.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"
#include "nn/gsm/pixel_branch_reference.h"
#include "nn/gsm/sky_reference.h"
#include "nn/gsm/voxel_heads_reference.h"
#include "nn/gsm/voxel_unet_reference.h"
#include "nn/safetensors.h"

#include <string>
#include <vector>

namespace icube::nn {

struct GsmConfig {
  std::string source;  // the file, for messages
  ConvEncoderConfig conv;
  Dav2Config dav2;
  SkyConfig sky;
  VoxelUnetConfig voxel_unet;
  VoxelHeadsConfig voxel_heads;
  PixelBranchConfig pixel;
  int64_t sky_panorama_rows = 256;  // the official visualisation's latitude-longitude grid (rows x 2 rows)
};

// A case config's JSON object (keys "hparams" and "dav2_config"); every failure names `source` and the key.
GsmConfig gsm_config_from_json(const nlohmann::json& config, const std::string& source);
GsmConfig read_gsm_config(const std::string& path);

// Checks the inputs fit the configuration before any work (image size, views); scene::InputError otherwise.
void check_gsm_inputs(const GsmConfig& c, const GsmInputs& in, const std::string& inputs_dir);

struct GsmElementOutputs {
  VoxelGaussians voxel;
  PixelGaussians pixel;
};

struct GsmOutputs {
  std::vector<GsmElementOutputs> elements;  // one per batch element
  CpuTensor sky_tokens;                     // [B, embed_dim]
  CpuTensor sky_image;                      // [B, N, H, W, 3]
  CpuTensor sky_panorama;                   // [B, rows, 2 rows, 3]
};

GsmOutputs gsm_forward_reference(const GsmConfig& c, const GsmWeights& w, const GsmInputs& in, GsmTrace* trace);

// The outputs under the reference case's names (outputs.safetensors): gs.b<i>.voxel.*, gs.b<i>.pixel.*,
// sky.tokens, sky.image, sky.panorama; index tensors as I32.
std::vector<TensorToWrite> gsm_output_tensors(const GsmOutputs& out);
// A trace's tensors (F32), sorted by name.
std::vector<TensorToWrite> gsm_trace_tensors(const GsmTrace& trace);

}  // namespace icube::nn
