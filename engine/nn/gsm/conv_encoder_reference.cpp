// The GSM's conv image encoder on the CPU; see conv_encoder_reference.h.
#include "nn/gsm/conv_encoder_reference.h"

#include "kernels/nn/batch_norm.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/elementwise.h"
#include "kernels/nn/group_norm.h"
#include "nn/gsm/gsm_json.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::nn {

namespace {

const std::string kPrefix = "img_encoder.encoders.conv.project_head.";

CpuTensor batch_norm_of(const GsmWeights& w, const std::string& p, const CpuTensor& x) {
  return cpu::batch_norm(x, w.at(p + "weight"), w.at(p + "bias"), w.at(p + "running_mean"), w.at(p + "running_var"), 1e-5);
}

// normalization() of InfiniCube's basic modules is GroupNorm32 (32 groups, computed in float32).
CpuTensor norm_of(const GsmWeights& w, const std::string& p, const CpuTensor& x, bool group_norm) {
  return group_norm ? cpu::group_norm(x, 32, w.at(p + "weight"), w.at(p + "bias"), 1e-5) : batch_norm_of(w, p, x);
}

CpuTensor relu(CpuTensor x) {
  for (float& v : x.data) v = std::max(v, 0.0f);
  return x;
}

// 2x2 average pooling, stride 2 (Downsample without a conv).
CpuTensor avg_pool2x2(const CpuTensor& x) {
  const int64_t BC = x.dim(0) * x.dim(1), H = x.dim(2), W = x.dim(3), OH = H / 2, OW = W / 2;
  CpuTensor y({x.dim(0), x.dim(1), OH, OW});
  for (int64_t bc = 0; bc < BC; ++bc)
    for (int64_t i = 0; i < OH; ++i)
      for (int64_t j = 0; j < OW; ++j) {
        const float* p = x.data.data() + (bc * H + 2 * i) * W + 2 * j;
        y.data[static_cast<size_t>((bc * OH + i) * OW + j)] =
            static_cast<float>((static_cast<double>(p[0]) + static_cast<double>(p[1]) + static_cast<double>(p[W]) +
                                static_cast<double>(p[W + 1])) / 4.0);
      }
  return y;
}

CpuTensor residual_block(const GsmWeights& w, const std::string& p, const CpuTensor& x, bool down, bool gn) {
  CpuTensor h = cpu::silu(norm_of(w, p + "in_layers.0.", x, gn));
  CpuTensor skip_in = x;
  if (down) {
    h = avg_pool2x2(h);
    skip_in = avg_pool2x2(x);
  }
  h = cpu::conv2d(h, w.at(p + "in_layers.2.weight"), &w.at(p + "in_layers.2.bias"), 1, 1);
  h = cpu::silu(norm_of(w, p + "out_layers.0.", h, gn));
  h = cpu::conv2d(h, w.at(p + "out_layers.3.weight"), &w.at(p + "out_layers.3.bias"), 1, 1);
  const CpuTensor skip = w.has(p + "skip_connection.weight")
                             ? cpu::conv2d(skip_in, w.at(p + "skip_connection.weight"), &w.at(p + "skip_connection.bias"), 1, 0)
                             : skip_in;
  return cpu::add(h, skip);
}

}  // namespace

ConvEncoderConfig conv_encoder_config_from_json(const nlohmann::json& hparams) {
  const std::string base = "encoder.conv_params.";
  ConvEncoderConfig c;
  c.filters = gsm_json::list<int>(hparams, base + "n_filter_list");
  c.strides = gsm_json::list<int>(hparams, base + "n_stride_list");
  c.kernels = gsm_json::list<int>(hparams, base + "n_kernel_list");
  c.paddings = gsm_json::list<int>(hparams, base + "n_padding_list");
  const size_t stages = c.filters.size() - 1;
  if (c.filters.size() < 2 || c.strides.size() != stages || c.kernels.size() != stages || c.paddings.size() != stages)
    throw scene::InputError("the GSM config", base + "n_filter_list",
                            "needs one more entry than n_stride_list, n_kernel_list and n_padding_list");
  // Absent lists take the official defaults: no residual stages, GroupNorm.
  c.residual = gsm_json::has(hparams, base + "n_residual_list") ? gsm_json::list<bool>(hparams, base + "n_residual_list")
                                                                : std::vector<bool>(stages, false);
  c.group_norm = gsm_json::has(hparams, base + "n_use_gn_list") ? gsm_json::list<bool>(hparams, base + "n_use_gn_list")
                                                                : std::vector<bool>(stages, true);
  if (c.residual.size() != stages || c.group_norm.size() != stages)
    throw scene::InputError("the GSM config", base + "n_residual_list", "needs one entry per stage");
  for (size_t i = 0; i < stages; ++i)
    if (c.residual[i] && c.kernels[i] != 3)
      throw scene::InputError("the GSM config", base + "n_kernel_list", "a residual stage's kernel must be 3");
  c.out_dim = gsm_json::integer(hparams, base + "conv_encoder_out_dim");
  return c;
}

CpuTensor conv_encoder_forward(const ConvEncoderConfig& c, const GsmWeights& w, const CpuTensor& images, GsmTrace* trace) {
  if (images.rank() != 4 || images.dim(1) != c.filters.front())
    throw std::invalid_argument("conv_encoder_forward: images " + images.shape_text() + " are not [V, " +
                                std::to_string(c.filters.front()) + ", H, W]");
  CpuTensor x = images;
  for (size_t i = 0; i + 1 < c.filters.size(); ++i) {
    const std::string p = kPrefix + std::to_string(i) + ".";
    if (c.residual[i]) {
      x = residual_block(w, p, x, c.strides[i] == 2, c.group_norm[i]);
    } else {
      x = cpu::conv2d(x, w.at(p + "0.weight"), &w.at(p + "0.bias"), c.strides[i], c.paddings[i]);
      x = relu(batch_norm_of(w, p + "1.", x));  // plain stages always take BatchNorm (n_use_gn_list is the residual blocks')
    }
    trace_put(trace, "enc.conv.project_head." + std::to_string(i), x);
  }
  return cpu::conv2d(x, w.at(kPrefix + "conv_1x1.weight"), &w.at(kPrefix + "conv_1x1.bias"), 1, 0);
}

}  // namespace icube::nn
