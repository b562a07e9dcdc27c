// Latent scale factor resolution; see latent_scale.h.
#include "nn/latent_scale.h"

#include "scene/input_error.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::nn {

LatentScale resolve_latent_scale(std::optional<double> flag, const SafetensorsFile& weights) {
  if (flag) {
    if (!(*flag > 0.0) || !std::isfinite(*flag))
      throw std::invalid_argument("--scale-factor " + std::to_string(*flag) + " is not a positive number");
    return {*flag, "--scale-factor"};
  }
  const auto it = weights.metadata().find("scale_factor");
  if (it == weights.metadata().end()) return {1.0, "none given (1)"};
  double v = 0.0;
  size_t used = 0;
  try {
    v = std::stod(it->second, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != it->second.size() || !(v > 0.0) || !std::isfinite(v))
    throw scene::InputError(weights.path(), "__metadata__.scale_factor",
                            "'" + scene::printable(it->second) + "' is not a positive finite number");
  return {v, weights.path() + " metadata"};
}

}  // namespace icube::nn
