// The configuration of InfiniCube's dense diffusion UNet: the official
// `UNetModel` constructor's keyword arguments under their official names
// (voxelgen/modules/diffusionmodules/openaimodel/unet_dense.py, including the
// misspelt `middile_force_spatial_transformer`), read from a JSON object (or
// from its "unet_kwargs" member, as ../shared/data/models/unet_small/config.json
// holds it). Arguments that do not change inference (dropout, use_checkpoint,
// use_fp16) are accepted; an unknown key, a wrong type, or a value the engine
// does not implement (dims other than 3, class or cross-attention conditioning,
// codebook prediction) is a scene::InputError naming the file and the key.
// Preset "infinicube-diffusion" is the released model (conventions §8.2).
#pragma once

#include <string>
#include <vector>

namespace icube::nn {

struct UNetConfig {
  int image_size = 64;
  int in_channels = 16;   // num_input_channels
  int out_channels = 8;   // -1: in_channels
  int model_channels = 192;
  int num_res_blocks = 2;
  std::vector<int> attention_resolutions{4, 8};
  std::vector<int> channel_mult{1, 2, 4, 4};
  bool conv_resample = true;
  int dims = 3;
  int num_heads = 8;
  int num_head_channels = -1;
  int num_heads_upsample = -1;
  bool use_scale_shift_norm = true;
  bool resblock_updown = true;
  bool use_spatial_transformer = false;
  int transformer_depth = 12;
  bool legacy = true;
  bool middle_force_spatial_transformer = true;  // `middile_force_spatial_transformer`
  bool middle_disable_first_sa = true;

  int outputs() const { return out_channels < 0 ? in_channels : out_channels; }
  int time_embed_dim() const { return 4 * model_channels; }
  // Every axis of the input grid is a multiple of this: the model halves it once per level
  // after the first (len(channel_mult) - 1 times).
  int64_t grid_multiple() const { return int64_t{1} << (channel_mult.empty() ? 0 : channel_mult.size() - 1); }
};

// Throws std::invalid_argument when an axis of the X x Y x Z input grid is not a multiple of
// c.grid_multiple(), naming the axis, the rule and the nearest sizes that follow it.
void check_unet_grid(const UNetConfig& c, int64_t X, int64_t Y, int64_t Z);

// Parses JSON text; `source` names the file in errors.
UNetConfig parse_unet_config(const std::string& json_text, const std::string& source);
// A file path, or a preset name: "infinicube-diffusion" (the released model) or "infinicube-diffusion-tiny"
// (its structure at 32 channels and 1.56 M parameters: smoke tests and benchmarks of the pipeline).
UNetConfig load_unet_config(const std::string& path_or_preset);
UNetConfig infinicube_diffusion_config();

}  // namespace icube::nn
