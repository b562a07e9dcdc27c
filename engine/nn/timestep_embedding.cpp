// The diffusion UNet's sinusoidal timestep embedding; see timestep_embedding.h.
#include "nn/timestep_embedding.h"

#include <cmath>

namespace icube::nn::cpu {

CpuTensor timestep_embedding(const std::vector<int64_t>& t, int dim, double max_period) {
  const int half = dim / 2;
  CpuTensor e({static_cast<int64_t>(t.size()), dim});
  const float c = static_cast<float>(-std::log(max_period));
  for (size_t b = 0; b < t.size(); ++b)
    for (int i = 0; i < half; ++i) {
      const float freq = std::exp(c * static_cast<float>(i) / static_cast<float>(half));
      const float arg = static_cast<float>(t[b]) * freq;
      e.data[b * static_cast<size_t>(dim) + static_cast<size_t>(i)] = std::cos(arg);
      e.data[b * static_cast<size_t>(dim) + static_cast<size_t>(half + i)] = std::sin(arg);
    }
  return e;  // an odd dim keeps its last entry 0, as upstream pads
}

}  // namespace icube::nn::cpu
