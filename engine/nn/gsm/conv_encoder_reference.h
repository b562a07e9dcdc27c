// The GSM's conv image encoder (InfiniCube ConvEncoder, gsm_small README step
// 2) as a plain CPU reference: per stage either conv + BatchNorm (running
// statistics) + ReLU, or a residual block h = conv3x3(SiLU(BN(x))),
// h = conv3x3(SiLU(BN(h))), y = skip(x) + h (skip: identity, or a 1x1 conv when
// the width changes; stride 2 = 2x2 average pooling of h and x before the
// first conv), then a 1x1 projection. Weights `img_encoder.encoders.conv.
// project_head.<i>.*` and `.conv_1x1.*`. Stage outputs are traced as
// enc.conv.project_head.<i>. Tests: tests/nn/test_gsm_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"

#include <nlohmann/json_fwd.hpp>

#include <vector>

namespace icube::nn {

struct ConvEncoderConfig {
  std::vector<int> filters;  // n_filter_list: input width, then one per stage
  std::vector<int> strides, kernels, paddings;
  std::vector<bool> residual;
  std::vector<bool> group_norm;  // n_use_gn_list: residual blocks' GroupNorm(32) instead of BatchNorm (the release: none)
  int out_dim = 0;               // conv_encoder_out_dim
};

// From hparams.encoder.conv_params (`hparams` = config.json's hparams object).
ConvEncoderConfig conv_encoder_config_from_json(const nlohmann::json& hparams);

// images [V, 3, H, W] in [0, 1] -> features [V, out_dim, H', W'].
CpuTensor conv_encoder_forward(const ConvEncoderConfig& c, const GsmWeights& w, const CpuTensor& images, GsmTrace* trace);

}  // namespace icube::nn
