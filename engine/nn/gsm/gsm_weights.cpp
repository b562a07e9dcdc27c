// The GSM reference's weight lookup and checked loading; see gsm_weights.h.
#include "nn/gsm/gsm_weights.h"

#include "nn/safetensors.h"
#include "scene/input_error.h"

#include <set>

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

namespace {

// num_batches_tracked is a 0-d int64 in PyTorch; writers that cannot store 0-d tensors give it shape [1].
bool shape_fits(const GsmParamSpec& s, const std::vector<int64_t>& shape) {
  if (s.role == GsmTensorRole::BatchCount) return shape.empty() || shape == std::vector<int64_t>{1};
  return shape == s.shape;
}

}  // namespace

void check_gsm_weight_file(const SafetensorsFile& file, const std::vector<GsmParamSpec>& specs) {
  std::set<std::string> wanted;
  for (const GsmParamSpec& s : specs) {
    const std::string where = "tensor '" + s.name + "'";
    const TensorInfo* t = file.find(s.name);
    if (!t) throw scene::InputError(file.path(), where, "missing (the GSM needs " + shape_text(s.shape) + ")");
    if (!shape_fits(s, t->shape))
      throw scene::InputError(file.path(), where, "shape " + t->shape_text() + ", the GSM needs " + shape_text(s.shape));
    const bool integer_ok = s.integer() && (t->dtype == DType::I64 || t->dtype == DType::I32);
    if (!dtype_is_float(t->dtype) && !integer_ok)
      throw scene::InputError(file.path(), where,
                              std::string("dtype ") + dtype_name(t->dtype) +
                                  (s.integer() ? ": a batch count must be I64, I32 or a float type"
                                               : ": a parameter must be F32, F16 or BF16"));
    wanted.insert(s.name);
  }
  for (const TensorInfo& t : file.tensors())
    if (!wanted.count(t.name))
      throw scene::InputError(file.path(), "tensor '" + scene::printable(t.name) + "'", "unexpected: the GSM has no such tensor");
}

GsmWeights load_gsm_weights(const std::string& path, const std::vector<GsmParamSpec>& specs, bool check_finite) {
  const SafetensorsFile file(path);
  check_gsm_weight_file(file, specs);
  GsmWeights w;
  w.source = path;
  for (const GsmParamSpec& s : specs) {
    const TensorInfo& t = *file.find(s.name);
    if (check_finite)
      if (const int64_t i = file.first_non_finite(t); i >= 0)
        throw scene::InputError(path, "tensor '" + s.name + "'", "element " + std::to_string(i) + " is not finite (NaN or infinity)");
    w.tensors.emplace(s.name, CpuTensor(s.shape, file.to_f32(t)));
  }
  return w;
}

}  // namespace icube::nn
