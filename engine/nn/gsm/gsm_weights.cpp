// The GSM reference's weight lookup; see gsm_weights.h.
#include "nn/gsm/gsm_weights.h"

#include "nn/safetensors.h"
#include "scene/input_error.h"

namespace icube::nn {

const CpuTensor& GsmWeights::at(const std::string& name) const {
  const auto it = tensors.find(name);
  if (it == tensors.end()) throw scene::InputError(source, "tensor '" + name + "'", "missing (the GSM needs it)");
  return it->second;
}

const CpuTensor& GsmWeights::at(const std::string& name, const std::vector<int64_t>& shape) const {
  const CpuTensor& t = at(name);
  if (t.shape != shape)
    throw scene::InputError(source, "tensor '" + name + "'", "shape " + t.shape_text() + ", the GSM needs " + shape_text(shape));
  return t;
}

GsmWeights load_gsm_weights(const std::string& path) {
  const SafetensorsFile file(path);
  GsmWeights w;
  w.source = path;
  for (const TensorInfo& t : file.tensors()) {
    if (const int64_t i = file.first_non_finite(t); i >= 0)
      throw scene::InputError(path, "tensor '" + t.name + "'", "element " + std::to_string(i) + " is not finite (NaN or infinity)");
    w.tensors.emplace(t.name, CpuTensor(t.shape, file.to_f32(t)));
  }
  return w;
}

}  // namespace icube::nn
