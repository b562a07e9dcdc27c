// InfiniCube's dense diffusion UNet (`UNetModel`, unet_dense.py) as a plain
// CPU reference over the layers' CPU references (kernels/nn/<op>.h): the module tree the official constructor
// builds for a UNetConfig, its parameters under the official state-dict names
// and shapes, and a forward pass that can report every block's output under
// the names of ../shared/data/models/unet_small/*.intermediates.safetensors
// (t_emb, emb, input_blocks.<i>, middle_block, output_blocks.<i>).
//
// The oracle for the GPU UNet to come, and the checker of weight files
// (parameters() lists what a file must hold). Float32 tensors between layers,
// double accumulation inside them. Tests: tests/nn/test_unet_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/param_spec.h"
#include "nn/unet_config.h"

#include <functional>
#include <map>
#include <string>
#include <vector>

namespace icube::nn {

class UNetReference {
 public:
  explicit UNetReference(const UNetConfig& config);

  const UNetConfig& config() const { return config_; }
  // Every parameter in construction order (the order of the official state dict).
  const std::vector<ParamSpec>& parameters() const { return params_; }
  uint64_t parameter_count() const;

  // Weights by official name; every parameter must be present with its shape.
  void set_weights(std::map<std::string, CpuTensor> weights);

  using Capture = std::function<void(const std::string& name, const CpuTensor& value)>;
  // x [B, in_channels, X, Y, Z], t [B] -> [B, out_channels, X, Y, Z].
  CpuTensor forward(const CpuTensor& x, const std::vector<int64_t>& t, const Capture& capture = {}) const;

  struct Layer;
  const std::vector<std::vector<Layer>>& input_blocks() const { return input_blocks_; }
  const std::vector<Layer>& middle_block() const { return middle_block_; }
  const std::vector<std::vector<Layer>>& output_blocks() const { return output_blocks_; }

  struct Layer {
    enum class Kind { Conv, Res, Attn, Transformer, Down, Up } kind = Kind::Conv;
    std::string prefix;  // e.g. "input_blocks.1.0"
    int in_ch = 0, out_ch = 0;
    bool up = false, down = false, resample_conv = false;
    int heads = 0, dim_head = 0, depth = 0;
    bool disable_sa = false;
  };

 private:
  void add_params(const Layer& l);
  void param(const std::string& name, std::vector<int64_t> shape);
  const CpuTensor& w(const std::string& name) const;
  CpuTensor run(const Layer& l, const CpuTensor& x, const CpuTensor& emb) const;
  CpuTensor res_block(const Layer& l, const CpuTensor& x, const CpuTensor& emb) const;
  CpuTensor attention_block(const Layer& l, const CpuTensor& x) const;
  CpuTensor spatial_transformer(const Layer& l, const CpuTensor& x) const;

  UNetConfig config_;
  std::vector<std::vector<Layer>> input_blocks_, output_blocks_;
  std::vector<Layer> middle_block_;
  std::vector<ParamSpec> params_;
  std::map<std::string, CpuTensor> weights_;
};

}  // namespace icube::nn
