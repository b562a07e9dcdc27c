// Vulkan error handling that stays on in release builds.
//
// VK_CHECK(call) evaluates a Vulkan call and throws when it does not return
// VK_SUCCESS (or another non-error code such as VK_INCOMPLETE). The exception
// names the call, the file and line, and the VkResult, so a user sees
// "vkQueueSubmit(...) failed: VK_ERROR_DEVICE_LOST at engine/gpu/commands.cpp:88"
// instead of a segfault. Device loss and out-of-memory have their own types so
// the CLI can print advice for them.
#pragma once

#include <vulkan/vulkan.h>

#include <stdexcept>
#include <string>

namespace icube::gpu {

// Any failure reported by the Vulkan driver or the loader.
class VulkanError : public std::runtime_error {
 public:
  VulkanError(VkResult result, const std::string& message)
      : std::runtime_error(message), result_(result) {}
  VkResult result() const { return result_; }

 private:
  VkResult result_;
};

// VK_ERROR_DEVICE_LOST: the device hung or was reset; nothing on it is usable.
class DeviceLostError : public VulkanError {
 public:
  using VulkanError::VulkanError;
};

// VK_ERROR_OUT_OF_{HOST,DEVICE}_MEMORY or a failed allocation.
class OutOfMemoryError : public VulkanError {
 public:
  using VulkanError::VulkanError;
};

const char* result_name(VkResult result);

// Throws the matching exception type for `result`; `what` names the failed call.
[[noreturn]] void throw_vulkan_error(VkResult result, const char* what, const char* file, int line);

}  // namespace icube::gpu

#define VK_CHECK(call)                                                                  \
  do {                                                                                  \
    VkResult icube_vk_result_ = (call);                                                 \
    if (icube_vk_result_ < 0)                                                           \
      ::icube::gpu::throw_vulkan_error(icube_vk_result_, #call, __FILE__, __LINE__);    \
  } while (0)
