// The GSM's conv image encoder on the GPU (the layers of
// conv_encoder_reference.h through the LayerRecorder): conv2d, folded
// BatchNorm with its ReLU / SiLU fused (gsm_gpu_weights.h), the residual
// blocks' skip and sum, the 1x1 projection. GroupNorm residual blocks and
// stride-2 stages (neither in the released model) are refused when the
// configuration is read for the GPU. Tests: tests/nn/test_gsm_gpu.cpp.
#pragma once

#include "nn/device_tensor.h"
#include "nn/gsm/conv_encoder_reference.h"
#include "nn/layer_recorder.h"

namespace icube::nn {

// Throws scene::InputError naming the key when a stage is one the GPU encoder does not implement.
void check_conv_encoder_gpu(const ConvEncoderConfig& c, const std::string& source);

// images [V, 3, H, W] -> [V, out_dim, H, W]; `stages` receives each stage's output (enc.conv.project_head.<i>)
// when not null.
DeviceTensor conv_encoder_gpu(LayerRecorder& L, const ConvEncoderConfig& c, const DeviceTensor& images,
                              std::vector<DeviceTensor>* stages = nullptr);

}  // namespace icube::nn
