// The GSM's Depth-Anything-V2 image features, CPU reference (InfiniCube's
// DAV2Encoder: voxelgen/modules/gsm_modules/encoder/modules/dav2_encoder.py
// with its copy of HF transformers' DepthAnythingForDepthEstimation.forward_fusion).
// Per view: bilinear resize of the [0, 1] image to the target input size,
// ImageNet normalisation, the DINOv2 backbone (patch embedding, CLS token,
// bicubically resized position grid, pre-norm layers with layer scale), the
// final LayerNorm on the selected layers' outputs, the DPT neck (reassemble,
// 3x3 convs, fusion from the coarsest map up) and the last fusion map through
// the upsampler's residual blocks. The depth head is not run.
// Widths, layer counts and selected layers come from config.json (`dav2_config`,
// `hparams.encoder.dav2_params`); the weights are img_encoder.encoders.dav2.*.
// Test: tests/nn/test_gsm_dav2_reference.cpp (every enc.dav2.* of gsm_small).
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <vector>

namespace icube::nn {

// Depth-Anything's input normalisation (ImageNet's mean and std, float32 as the official transform holds them).
constexpr float kImageNetMean[3] = {0.485f, 0.456f, 0.406f};
constexpr float kImageNetStd[3] = {0.229f, 0.224f, 0.225f};

// One of the upsampler's residual blocks (basic_modules.ResBlock, 2-D).
struct Dav2UpsamplerBlock {
  int64_t out_dim = 0;
  bool up = false;          // nearest x2 (takes precedence over down, as the official block)
  bool down = false;        // 2x2 average pooling
  bool group_norm = false;  // GroupNorm(32) instead of BatchNorm (running statistics)
};

struct Dav2Config {
  // DINOv2 backbone (dav2_config.backbone_config).
  int64_t hidden_size = 0, num_layers = 0, num_heads = 0, patch_size = 0;
  int64_t mlp_hidden = 0;     // int(hidden_size * mlp_ratio)
  int64_t position_grid = 0;  // image_size / patch_size: the learned position grid is position_grid^2
  double layer_norm_eps = 1e-6;
  bool use_swiglu_ffn = false;
  bool apply_layernorm = true;       // the final LayerNorm on each selected hidden state
  std::vector<int64_t> out_indices;  // hidden-state indices (0 = embeddings, i = output of layer i - 1)
  // DPT neck (dav2_config).
  std::vector<int64_t> neck_hidden_sizes;
  std::vector<double> reassemble_factors;  // > 1: transposed conv, 1: identity, 1/k: 3x3 conv stride k
  int64_t fusion_hidden_size = 0;
  // DAV2Encoder (hparams.encoder.dav2_params).
  int64_t input_height = 0, input_width = 0;  // target_input_size
  std::vector<Dav2UpsamplerBlock> upsampler;
};

// From the whole config.json object (keys `dav2_config` and `hparams.encoder.dav2_params`).
// Throws std::invalid_argument naming a missing key or an unsupported value.
Dav2Config dav2_config_from_json(const nlohmann::json& case_config);

// images [V, 3, H, W] RGB in [0, 1] (V = B * N views, view-major within a batch element) ->
// [V, C_out, h, w] (C_out = the last upsampler width). The trace gets enc.dav2.pixel_values,
// pos_embed_interp, embeddings, layer.<i>, feature_maps.<k>, reassemble.<k>, neck_conv.<k>,
// fusion.<k>, upsampler.<j> (all blocks but the last), all with V first, and enc.dav2.out as
// [batch, V / batch, C_out, h, w] (the official encoder's [B, N, ...] output).
CpuTensor dav2_features(const Dav2Config& cfg, const GsmWeights& weights, const CpuTensor& images,
                        GsmTrace* trace = nullptr, int64_t batch = 1);

}  // namespace icube::nn
