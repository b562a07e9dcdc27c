// The GSM's state dict from its configuration alone: every tensor that
// gsm.Model.state_dict() holds (names, shapes, in state-dict order) for a
// config in the form of ../shared/data/models/gsm_small/config.json, and the
// name or file that picks the configuration.
//
// Included are the tensors the engine reads and those the model carries but the
// forward never runs (gsm_forward_reference reads the ones with run = true):
//   img_encoder.encoders.conv.*        conv stages (conv + BatchNorm, or a 2-D ResBlock), conv_1x1
//   img_encoder.encoders.dav2.model.*  Depth-Anything: DINOv2 backbone (embeddings with cls / mask token and
//                                      position grid, layers, final LayerNorm), DPT neck (reassemble, convs,
//                                      fusion; the coarsest fusion layer's residual_layer1 is never run) and
//                                      the relative-depth head (carried)
//   img_encoder.encoders.dav2.upsampler.*  2-D ResBlocks
//   skybox.*                           sky query, modulator, patch / position embedders, transformer layers
//   backbone.backbone_3d.*             lifter, sparse U-Net (encoders, bottlenecks, decoders), the structure
//                                      heads struct_convs (carried), pre_conv, the two Gaussian heads
//   backbone.backbone_2d.*             x-unet 0.4.0 and linear_out
// BatchNorm layers add running_mean, running_var (buffers) and num_batches_tracked (an int64 buffer of
// shape []; the reference case stores it as [1], which the loader accepts).
// The released configuration reproduces ../shared/reference/models/gsm.tsv exactly (887 tensors,
// 360,738,506 parameters); gsm_small's config reproduces its weights.safetensors.
//
// Presets: "infinicube-gsm" names the released configuration (assets/models/infinicube-gsm.json, built into
// the engine: nn/gsm/gsm_preset.h); anything else is a config file.
// Test: tests/nn/test_gsm_params.cpp.
#pragma once

#include "nn/gsm/gsm_reference.h"
#include "nn/gsm/gsm_weights.h"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace icube::nn {

// What shapes the state dict beyond GsmConfig: Depth-Anything settings of tensors the forward does not
// read, or reads only when present (dav2_config).
struct GsmParamExtras {
  int64_t dav2_head_hidden_size = 0;  // head_hidden_size: the relative-depth head's width (carried, not run)
  bool dav2_qkv_bias = true;          // backbone_config.qkv_bias: query / key / value biases
  bool dav2_mask_token = true;        // backbone_config.use_mask_token: embeddings.mask_token (carried, not run)
};

// From a config's whole JSON object (dav2_config); qkv_bias and use_mask_token default to DINOv2's (true).
GsmParamExtras gsm_param_extras_from_json(const nlohmann::json& config, const std::string& source);

struct GsmModelConfig {
  GsmConfig config;
  GsmParamExtras extras;
};

GsmModelConfig gsm_model_config_from_json(const nlohmann::json& config, const std::string& source);
// The preset "infinicube-gsm" or a config file; scene::InputError naming the file and the key.
GsmModelConfig load_gsm_model_config(const std::string& name_or_path);

std::vector<GsmParamSpec> gsm_param_specs(const GsmConfig& config, const GsmParamExtras& extras);
inline std::vector<GsmParamSpec> gsm_param_specs(const GsmModelConfig& m) { return gsm_param_specs(m.config, m.extras); }

// Elements of the parameters (buffers excluded) and of the buffers.
uint64_t gsm_parameter_count(const std::vector<GsmParamSpec>& specs);
uint64_t gsm_buffer_count(const std::vector<GsmParamSpec>& specs);

// load_gsm_weights(path, specs, check_finite) with the model's specs.
GsmWeights load_gsm_weights(const std::string& path, const GsmModelConfig& model, bool check_finite);

}  // namespace icube::nn
