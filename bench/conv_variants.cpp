#include "conv_variants.h"

#include "gpu/device_info.h"

#include <cstdio>
#include <stdexcept>

namespace icube::bench {

std::vector<ConvVariant> conv_variants(const std::vector<std::string>& names, const gpu::DeviceInfo& device,
                                       const std::string& option) {
  using kernels::nn::Conv3dPath;
  std::vector<ConvVariant> out;
  for (const std::string& v : names) {
    const bool f16 = v.size() > 5 && v.compare(v.size() - 5, 5, "-fp16") == 0;
    const std::string base = f16 ? v.substr(0, v.size() - 5) : v;
    Conv3dPath path;
    if (base == "register") path = Conv3dPath::kRegisterTile;
    else if (base == "tiled") path = Conv3dPath::kSharedTile;
    else if (base == "coopmat") path = Conv3dPath::kCoopMatrix;
    else if (base == "emulated") path = Conv3dPath::kCoopMatrixEmulated;
    else throw std::invalid_argument(option + ": unknown variant " + v + " (register, tiled, coopmat, emulated, each optionally -fp16)");
    if (const std::string why = kernels::nn::conv3d_path_unavailable(path, device); !why.empty()) {
      std::printf("(%s skipped: %s)\n", v.c_str(), why.c_str());
      continue;
    }
    out.push_back({v, path, f16});
  }
  return out;
}

}  // namespace icube::bench
