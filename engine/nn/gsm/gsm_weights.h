// The GSM's weights for its CPU reference: every tensor of a .safetensors file
// under its official state-dict name (gsm.Model.state_dict(): img_encoder.*,
// skybox.*, backbone.*), as float32, with a lookup that names the file and the
// tensor when one is missing or has the wrong shape (scene::InputError).
// Tests: through the GSM reference (tests/nn/test_gsm_*.cpp).
#pragma once

#include "kernels/nn/cpu_tensor.h"

#include <map>
#include <string>
#include <vector>

namespace icube::nn {

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

}  // namespace icube::nn
