// The convolution kernels a benchmark runs side by side, named on its command
// line as "register", "tiled", "coopmat", "emulated", each optionally "-fp16"
// (fp16 packed weights; the cooperative-matrix paths' operands are fp16
// either way): icube-bench-nn's --conv-paths, icube-bench-sparse's --sparse-paths.
#pragma once

#include "kernels/nn/conv3d.h"

#include <string>
#include <vector>

namespace icube::gpu {
struct DeviceInfo;
}

namespace icube::bench {

struct ConvVariant {
  std::string name;  // as given
  kernels::nn::Conv3dPath path = kernels::nn::Conv3dPath::kRegisterTile;
  bool f16 = false;
};

// The variants in order; a path `device` cannot run (kernels::nn::conv3d_path_unavailable) is left out with a
// printed note. std::invalid_argument naming `option` on an unknown name.
std::vector<ConvVariant> conv_variants(const std::vector<std::string>& names, const gpu::DeviceInfo& device,
                                       const std::string& option);

}  // namespace icube::bench
