// Weight-file binding by official names; see weights.h.
#include "nn/weights.h"

#include "scene/input_error.h"

#include <algorithm>
#include <set>

namespace icube::nn {

namespace {

std::string without_dots(std::string s) {
  s.erase(std::remove(s.begin(), s.end(), '.'), s.end());
  return s;
}


}  // namespace

std::map<std::string, std::string> resolve_weights(const SafetensorsFile& file, const std::vector<ParamSpec>& params,
                                                   const WeightOptions& o) {
  const std::string live = o.model_prefix + ".", ema = o.model_prefix + "_ema.";
  bool has_live = false, has_ema = false, has_bare = false;
  for (const TensorInfo& t : file.tensors()) {
    if (t.name.rfind(ema, 0) == 0) has_ema = true;
    else if (t.name.rfind(live, 0) == 0) has_live = true;
    else has_bare = true;
  }
  enum class Mode { Bare, Live, Ema } mode = Mode::Bare;
  if (o.ema) {
    if (!has_ema)
      throw scene::InputError(file.path(), "", "--ema: the file has no EMA copy (no tensor named " + ema + "*)");
    mode = Mode::Ema;
  } else if (has_live) {
    mode = Mode::Live;
  } else if (has_ema && !has_bare) {
    mode = Mode::Ema;  // only the EMA copy is there
  }
  auto file_name = [&](const std::string& p) {
    return mode == Mode::Bare ? p : mode == Mode::Live ? live + p : ema + without_dots(p);
  };
  std::map<std::string, std::string> out;
  std::set<std::string> wanted;
  for (const ParamSpec& p : params) {
    const std::string name = file_name(p.name);
    const TensorInfo* t = file.find(name);
    if (!t)
      throw scene::InputError(file.path(), "tensor '" + name + "'",
                              "missing (the model needs " + shape_text(p.shape) + ")");
    if (t->shape != p.shape)
      throw scene::InputError(file.path(), "tensor '" + name + "'",
                              "shape " + t->shape_text() + ", the model needs " + shape_text(p.shape));
    out[p.name] = name;
    wanted.insert(name);
  }
  // Unexpected tensors in the chosen namespace.
  for (const TensorInfo& t : file.tensors()) {
    const bool in_namespace = mode == Mode::Bare   ? t.name.rfind(live, 0) != 0 && t.name.rfind(ema, 0) != 0 &&
                                                         t.name.find('.') != std::string::npos
                              : mode == Mode::Live ? t.name.rfind(live, 0) == 0
                                                   : t.name.rfind(ema, 0) == 0;
    const std::string inner = mode == Mode::Bare ? t.name : t.name.substr(mode == Mode::Live ? live.size() : ema.size());
    bool ignored = false;
    for (const std::string& p : o.ignore_prefixes) ignored = ignored || inner.rfind(mode == Mode::Ema ? without_dots(p) : p, 0) == 0;
    const bool other_model = o.model_prefix != "vae" && t.name.rfind("vae.", 0) == 0;  // the VAE beside the UNet
    if (in_namespace && !ignored && !other_model && !wanted.count(t.name))
      throw scene::InputError(file.path(), "tensor '" + scene::printable(t.name) + "'",
                              "unexpected: the model has no such parameter");
  }
  return out;
}

std::map<std::string, CpuTensor> load_weights_cpu(const SafetensorsFile& file, const std::vector<ParamSpec>& params,
                                                  const WeightOptions& o) {
  const std::map<std::string, std::string> names = resolve_weights(file, params, o);
  std::map<std::string, CpuTensor> out;
  for (const ParamSpec& p : params) {
    const TensorInfo& t = *file.find(names.at(p.name));
    if (!dtype_is_float(t.dtype))
      throw scene::InputError(file.path(), "tensor '" + t.name + "'",
                              std::string("dtype ") + dtype_name(t.dtype) + ": a parameter must be F32, F16 or BF16");
    if (o.check_finite)
      if (const int64_t i = file.first_non_finite(t); i >= 0)
        throw scene::InputError(file.path(), "tensor '" + t.name + "'",
                                "element " + std::to_string(i) + " is not finite (NaN or infinity)");
    out.emplace(p.name, CpuTensor(p.shape, file.to_f32(t)));
  }
  return out;
}

}  // namespace icube::nn
