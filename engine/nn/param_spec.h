// A network parameter as the official state dict names it: its name and shape.
// Each network lists its parameters in construction order (UNetReference::parameters,
// vae_param_specs); weight files are checked and GPU parameter stores filled against the list.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace icube::nn {

struct ParamSpec {
  std::string name;
  std::vector<int64_t> shape;
};

}  // namespace icube::nn
