// Downsample as one 2x2 stride-2 conv2d: the weight permutation and the conv shape; see space_to_depth.h.
#include "kernels/nn/space_to_depth.h"

#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

std::vector<float> space_to_depth_conv_weights(const std::vector<float>& w1, uint32_t out_channels, uint32_t in_channels) {
  const uint64_t co = out_channels, ci = in_channels;
  if (w1.size() != co * ci * 4)
    throw std::invalid_argument("space_to_depth: " + std::to_string(w1.size()) + " weights for a 1x1 conv [" +
                                std::to_string(co) + ", 4 x " + std::to_string(ci) + "]");
  std::vector<float> w2(w1.size());
  for (uint64_t o = 0; o < co; ++o)
    for (uint64_t c = 0; c < ci; ++c)
      for (uint64_t dy = 0; dy < 2; ++dy)
        for (uint64_t dx = 0; dx < 2; ++dx)
          w2[static_cast<size_t>(((o * ci + c) * 2 + dy) * 2 + dx)] = w1[static_cast<size_t>(o * ci * 4 + c * 4 + dy * 2 + dx)];
  return w2;
}

Conv2dShape space_to_depth_conv_shape(uint32_t batch, uint32_t in_channels, uint32_t out_channels, uint32_t height,
                                      uint32_t width) {
  if (height % 2 || width % 2)
    throw std::invalid_argument("space_to_depth: the image " + std::to_string(height) + " x " + std::to_string(width) +
                                " is not divisible by 2 (x-unet's Downsample)");
  return Conv2dShape{batch, in_channels, out_channels, height, width, 2, 2, 2, 0};
}

}  // namespace icube::kernels::nn
