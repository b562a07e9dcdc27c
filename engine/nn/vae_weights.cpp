// VAE weight loading and the fVDB 0.2.0 kernel-axis conversion; see vae_weights.h.
#include "nn/vae_weights.h"

#include <stdexcept>

namespace icube::nn {

CpuTensor fvdb020_kernel_to_grid_order(const CpuTensor& w) {
  if (w.rank() != 5) throw std::invalid_argument("fvdb kernel order: weight " + w.shape_text() + " is not 5-D");
  const int64_t co = w.dim(0), ci = w.dim(1), k0 = w.dim(2), k1 = w.dim(3), k2 = w.dim(4);
  CpuTensor g({co, ci, k2, k1, k0});
  for (int64_t o = 0; o < co * ci; ++o)
    for (int64_t a = 0; a < k0; ++a)
      for (int64_t b = 0; b < k1; ++b)
        for (int64_t e = 0; e < k2; ++e)
          g.data[static_cast<size_t>(((o * k2 + e) * k1 + b) * k0 + a)] = w.data[static_cast<size_t>(((o * k0 + a) * k1 + b) * k2 + e)];
  return g;
}

std::map<std::string, CpuTensor> load_vae_weights_cpu(const SafetensorsFile& file, const VaeConfig& config, VaePart part,
                                                      WeightOptions options, FvdbKernelOrder order) {
  options.model_prefix = "vae";
  if (part == VaePart::Decoder)
    options.ignore_prefixes = {"encoder.", "unet.pre_conv.", "unet.encoders.", "unet.pre_kl_bottleneck."};
  else if (part == VaePart::Encoder)
    options.ignore_prefixes = {"unet.post_kl_bottleneck.", "unet.decoders.", "unet.struct_convs.", "unet.semantic_head."};
  std::map<std::string, CpuTensor> w = load_weights_cpu(file, vae_param_specs(config, part), options);
  if (order == FvdbKernelOrder::Fvdb020Reversed)
    for (auto& [name, t] : w)
      if (t.rank() == 5 && t.dim(2) > 1) t = fvdb020_kernel_to_grid_order(t);
  return w;
}

}  // namespace icube::nn
