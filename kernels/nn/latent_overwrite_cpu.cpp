// Outpainting's overwrite, CPU reference; see latent_overwrite.h.
#include "kernels/nn/latent_overwrite.h"

namespace icube::nn::cpu {

void latent_overwrite(std::vector<float>& x, const std::vector<uint32_t>& mask, const std::vector<float>& known,
                      float sqrt_alpha, float sqrt_beta, const std::vector<float>* z) {
  const size_t spatial = mask.size();
  for (size_t i = 0; i < x.size(); ++i)
    if (mask[i % spatial]) x[i] = z ? sqrt_alpha * known[i] + sqrt_beta * (*z)[i] : known[i];
}

}  // namespace icube::nn::cpu
