// Seeded random weights; see random_weights.h.
#include "nn/random_weights.h"

#include <cmath>
#include <random>

namespace icube::nn {

namespace {

bool ends_with(const std::string& s, const std::string& t) {
  return s.size() >= t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
}

std::string module_of(const std::string& name) { return name.substr(0, name.rfind('.')); }

bool is_norm(const ParamSpec& p) {
  const std::string m = module_of(p.name);
  return p.shape.size() == 1 && (m.find("GroupNorm") != std::string::npos || m.find("norm") != std::string::npos ||
                                 m.find("_gn") != std::string::npos);
}

}  // namespace

std::map<std::string, CpuTensor> random_weights(const std::vector<ParamSpec>& params, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::map<std::string, int64_t> fan_in;  // module -> fan-in of its weight
  for (const ParamSpec& p : params)
    if (ends_with(p.name, ".weight") && p.shape.size() >= 2) fan_in[module_of(p.name)] = CpuTensor::count(p.shape) / p.shape[0];
  std::map<std::string, CpuTensor> out;
  for (const ParamSpec& p : params) {
    CpuTensor t(p.shape);
    const bool weight = ends_with(p.name, ".weight");
    if (is_norm(p)) {
      for (float& v : t.data) v = (weight ? 1.0f : 0.0f) + 0.1f * normal(rng);
    } else if (ends_with(module_of(p.name), "embed_fn")) {  // nn.Embedding tables
      for (float& v : t.data) v = normal(rng);
    } else {
      const auto f = fan_in.find(module_of(p.name));
      const float bound = 1.0f / std::sqrt(static_cast<float>(f != fan_in.end() ? f->second : std::max<int64_t>(1, p.shape.back())));
      std::uniform_real_distribution<float> u(-bound, bound);
      for (float& v : t.data) v = u(rng);
    }
    out.emplace(p.name, std::move(t));
  }
  return out;
}

}  // namespace icube::nn
