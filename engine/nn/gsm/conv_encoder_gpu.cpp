// The GSM's conv image encoder on the GPU; see conv_encoder_gpu.h.
#include "nn/gsm/conv_encoder_gpu.h"

#include "scene/input_error.h"

#include <string>

namespace icube::nn {

namespace {

using kernels::nn::BatchNormActivation;

const std::string kPrefix = "img_encoder.encoders.conv.project_head.";

DeviceTensor folded_bn(LayerRecorder& L, const DeviceTensor& x, const std::string& p, BatchNormActivation act) {
  return L.channel_affine(x, p + "bn_scale", p + "bn_shift", act);
}

}  // namespace

void check_conv_encoder_gpu(const ConvEncoderConfig& c, const std::string& source) {
  for (size_t i = 0; i + 1 < c.filters.size(); ++i) {
    if (c.residual[i] && c.group_norm[i])
      throw scene::InputError(source, "hparams.encoder.conv_params.n_use_gn_list",
                              "GroupNorm residual blocks are not implemented on the GPU (the release uses BatchNorm)");
    if (c.residual[i] && c.strides[i] != 1)
      throw scene::InputError(source, "hparams.encoder.conv_params.n_stride_list",
                              "stride-2 residual blocks are not implemented on the GPU (the release uses stride 1)");
  }
}

DeviceTensor conv_encoder_gpu(LayerRecorder& L, const ConvEncoderConfig& c, const DeviceTensor& images,
                              std::vector<DeviceTensor>* stages) {
  DeviceTensor x = images;
  for (size_t i = 0; i + 1 < c.filters.size(); ++i) {
    const std::string p = kPrefix + std::to_string(i) + ".";
    if (c.residual[i]) {
      DeviceTensor h = folded_bn(L, x, p + "in_layers.0.", BatchNormActivation::silu);
      h = L.conv2d(h, p + "in_layers.2", 1, 1);
      h = folded_bn(L, h, p + "out_layers.0.", BatchNormActivation::silu);
      h = L.conv2d(h, p + "out_layers.3", 1, 1);
      const DeviceTensor skip = L.params().has(p + "skip_connection.weight") ? L.conv2d(x, p + "skip_connection", 1, 0) : x;
      x = L.add(skip, h);
    } else {
      x = L.conv2d(x, p + "0", static_cast<uint32_t>(c.strides[i]), static_cast<uint32_t>(c.paddings[i]));
      x = folded_bn(L, x, p + "1.", BatchNormActivation::relu);
    }
    if (stages) stages->push_back(x);
  }
  return L.conv2d(x, kPrefix + "conv_1x1", 1, 0);
}

}  // namespace icube::nn
