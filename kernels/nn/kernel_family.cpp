// The network kernels' family per device; see kernel_family.h.
#include "kernels/nn/kernel_family.h"

#include "gpu/device_info.h"

#include <cstdlib>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

KernelFamily kernel_family(const gpu::DeviceInfo& device) {
  if (const char* env = std::getenv("ICUBE_NN_KERNELS"); env && *env) {
    const std::string v = env;
    if (v == "lavapipe") return KernelFamily::kLavapipe;
    if (v == "gpu") return KernelFamily::kGpu;
    throw std::invalid_argument("ICUBE_NN_KERNELS=" + v + ": expected lavapipe or gpu");
  }
  return device.type == VK_PHYSICAL_DEVICE_TYPE_CPU ? KernelFamily::kLavapipe : KernelFamily::kGpu;
}

}  // namespace icube::kernels::nn
