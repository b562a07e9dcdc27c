#include "gpu/vk_check.h"

#include <cstring>

namespace icube::gpu {

const char* result_name(VkResult result) {
  switch (result) {
#define ICUBE_RESULT_CASE(r) \
  case r:                    \
    return #r;
    ICUBE_RESULT_CASE(VK_SUCCESS)
    ICUBE_RESULT_CASE(VK_NOT_READY)
    ICUBE_RESULT_CASE(VK_TIMEOUT)
    ICUBE_RESULT_CASE(VK_EVENT_SET)
    ICUBE_RESULT_CASE(VK_EVENT_RESET)
    ICUBE_RESULT_CASE(VK_INCOMPLETE)
    ICUBE_RESULT_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    ICUBE_RESULT_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    ICUBE_RESULT_CASE(VK_ERROR_INITIALIZATION_FAILED)
    ICUBE_RESULT_CASE(VK_ERROR_DEVICE_LOST)
    ICUBE_RESULT_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    ICUBE_RESULT_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    ICUBE_RESULT_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    ICUBE_RESULT_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    ICUBE_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    ICUBE_RESULT_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    ICUBE_RESULT_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    ICUBE_RESULT_CASE(VK_ERROR_FRAGMENTED_POOL)
    ICUBE_RESULT_CASE(VK_ERROR_UNKNOWN)
    ICUBE_RESULT_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
    ICUBE_RESULT_CASE(VK_ERROR_INVALID_EXTERNAL_HANDLE)
    ICUBE_RESULT_CASE(VK_ERROR_FRAGMENTATION)
    ICUBE_RESULT_CASE(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
    ICUBE_RESULT_CASE(VK_ERROR_SURFACE_LOST_KHR)
    ICUBE_RESULT_CASE(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
    ICUBE_RESULT_CASE(VK_SUBOPTIMAL_KHR)
    ICUBE_RESULT_CASE(VK_ERROR_OUT_OF_DATE_KHR)
    ICUBE_RESULT_CASE(VK_ERROR_VALIDATION_FAILED_EXT)
#undef ICUBE_RESULT_CASE
    default:
      return "VK_RESULT_UNKNOWN";
  }
}

void throw_vulkan_error(VkResult result, const char* what, const char* file, int line) {
  // Keep only the path below the repository root to make messages short.
  const char* short_file = file;
  for (const char* marker : {"/engine/", "/kernels/", "/tools/", "/viewer/", "/tests/", "/bench/"}) {
    if (const char* p = std::strstr(file, marker)) {
      short_file = p + 1;
      break;
    }
  }
  std::string message = std::string(what) + " failed: " + result_name(result) + " at " + short_file + ":" +
                        std::to_string(line);
  switch (result) {
    case VK_ERROR_DEVICE_LOST:
      throw DeviceLostError(result, message + " (the GPU hung or was reset; rerun with ICUBE_VALIDATION=1)");
    case VK_ERROR_OUT_OF_HOST_MEMORY:
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
      throw OutOfMemoryError(result, message + " (out of memory; try a smaller scene or another device)");
    default:
      throw VulkanError(result, message);
  }
}

}  // namespace icube::gpu
