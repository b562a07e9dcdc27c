// The GSM's weights for its CPU reference: tensors of a .safetensors file
// under their official state-dict names (gsm.Model.state_dict(): img_encoder.*,
// skybox.*, backbone.*), as float32, with a lookup that names the file and the
// tensor when one is missing or has the wrong shape (scene::InputError).
//
// Two loaders:
//   load_gsm_weights(path)                      every tensor of the file, each checked to be finite (the
//                                               reference cases, whose files are known to be complete);
//   load_gsm_weights(path, specs, check_finite) the file checked against the model's state dict first
//                                               (gsm_params.h lists it): every tensor present, each of its
//                                               shape, none unexpected, float dtypes (num_batches_tracked
//                                               may be an integer and [] or [1]), and with check_finite no
//                                               NaN or infinity. Every failure is a scene::InputError
//                                               naming the file and the tensor, before any value is read.
// Tests: tests/nn/test_gsm_params.cpp, and through the GSM reference (tests/nn/test_gsm_*.cpp).
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/param_spec.h"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace icube::nn {

class SafetensorsFile;

// What a state-dict tensor is, for checking a file and drawing random weights (gsm_random_weights.h).
enum class GsmTensorRole {
  Weight,             // a conv / linear weight (fan_in: its inputs per output, as torch counts them)
  Bias,               // a conv / linear bias (fan_in of its module's weight)
  NormWeight,         // BatchNorm / GroupNorm / LayerNorm weight, RMSNorm / LayerNorm gamma, DINOv2 layer scale
  NormBias,           // their biases
  Token,              // DINOv2 cls and mask tokens, position embeddings
  Query,              // the sky token's learned query
  RunningMean,        // BatchNorm buffers
  RunningVar,
  BatchCount,         // BatchNorm num_batches_tracked: int64, shape []
  VoxelGaussianBias,  // the voxel heads' OutConv bias: gsplat_upsample x group raw Gaussian values
  PixelGaussianBias,  // the pixel branch's linear_out bias: gs_per_pixel x group raw Gaussian values
};

// One tensor of gsm.Model.state_dict() (name and shape in ParamSpec).
struct GsmParamSpec : ParamSpec {
  GsmTensorRole role = GsmTensorRole::Weight;
  int64_t fan_in = 1;  // Weight, Bias, *GaussianBias
  int64_t group = 0;   // *GaussianBias: values per Gaussian (gs_dim)
  bool run = true;     // read by gsm_forward_reference; false: carried only (the DAV2 depth head, struct_convs, ...)

  bool buffer() const {
    return role == GsmTensorRole::RunningMean || role == GsmTensorRole::RunningVar || role == GsmTensorRole::BatchCount;
  }
  bool integer() const { return role == GsmTensorRole::BatchCount; }
};

struct GsmWeights {
  std::string source;  // the file, for messages
  std::map<std::string, CpuTensor> tensors;

  bool has(const std::string& name) const { return tensors.count(name) != 0; }
  // The tensor, or an InputError naming the source and the tensor.
  const CpuTensor& at(const std::string& name) const;
  // The tensor, checked to have `shape`.
  const CpuTensor& at(const std::string& name, const std::vector<int64_t>& shape) const;
};

GsmWeights load_gsm_weights(const std::string& path);

// The checks above on an open file, without reading any value.
void check_gsm_weight_file(const SafetensorsFile& file, const std::vector<GsmParamSpec>& specs);
GsmWeights load_gsm_weights(const std::string& path, const std::vector<GsmParamSpec>& specs, bool check_finite);

}  // namespace icube::nn
