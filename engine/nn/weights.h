// Binding a weight file to a model's parameters (official state-dict names).
//
// A file holds the parameters under their bare names, or under a Lightning
// checkpoint's prefixes: `unet.<name>` (live weights) and `unet_ema.<name
// with the dots removed>` (the EMA copy). `ema` picks the EMA copy; without it
// the bare or `unet.` names are used. Other tensors of the file (`vae.*`, the
// other copy, `scale_factor`) are ignored; a tensor in the chosen namespace
// that the model does not have is an error, as is a missing tensor or one of
// the wrong shape. F16/BF16 tensors are converted to float32. Every error is a
// scene::InputError naming the file and the tensor.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/safetensors.h"
#include "nn/unet_reference.h"

#include <map>
#include <string>
#include <vector>

namespace icube::nn {

struct WeightOptions {
  bool ema = false;
  bool check_finite = false;
  std::string model_prefix = "unet";  // checkpoint prefix of this model's tensors
  // Tensors whose name (inside the chosen namespace) starts with one of these belong to a part of the
  // model not being loaded (the VAE's encoder when decoding): neither required nor unexpected.
  std::vector<std::string> ignore_prefixes;
};

// Which file name holds each parameter (parameter name -> file tensor name);
// the checks above, without reading any value.
std::map<std::string, std::string> resolve_weights(const SafetensorsFile& file, const std::vector<ParamSpec>& params,
                                                   const WeightOptions& options);

std::map<std::string, CpuTensor> load_weights_cpu(const SafetensorsFile& file, const std::vector<ParamSpec>& params,
                                                  const WeightOptions& options);

}  // namespace icube::nn
