// Seeded random weights of a model's official structure, for tests and
// benchmarks (no real checkpoint is shipped): the initialisation the project's
// reference cases use — conv/linear weights and biases U(±1/sqrt(fan_in)),
// normalisation weights 1 + 0.1·N(0,1) and biases 0.1·N(0,1), embeddings (modules named *embed_fn) N(0,1).
// A parameter is a normalisation one when its name has "GroupNorm", "norm" or
// "_gn" in its module path and it is 1-D.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/unet_reference.h"  // ParamSpec

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace icube::nn {

std::map<std::string, CpuTensor> random_weights(const std::vector<ParamSpec>& params, uint32_t seed);

}  // namespace icube::nn
