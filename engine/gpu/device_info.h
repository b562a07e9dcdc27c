// What the engine knows about one Vulkan physical device, and device selection.
//
// Lavapipe (VK_PHYSICAL_DEVICE_TYPE_CPU) is a first-class device: selection
// prefers discrete GPUs, then integrated, virtual and CPU devices, but never
// filters any out. ICUBE_DEVICE=<index|name substring> overrides the choice.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

namespace icube::gpu {

struct DeviceInfo {
  uint32_t index = 0;  // position in vkEnumeratePhysicalDevices order
  VkPhysicalDevice handle = VK_NULL_HANDLE;
  std::string name;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  std::string driver_name;
  std::string driver_info;
  uint32_t api_version = 0;
  uint32_t vendor_id = 0;
  uint32_t device_id = 0;

  // Subgroups (lavapipe: LP_NATIVE_VECTOR_WIDTH / 32; never assume 32).
  uint32_t subgroup_size = 0;
  uint32_t min_subgroup_size = 0;
  uint32_t max_subgroup_size = 0;
  VkSubgroupFeatureFlags subgroup_operations = 0;
  bool subgroup_size_control = false;    // feature: requiredSubgroupSize may be set
  bool compute_full_subgroups = false;   // feature
  bool required_size_in_compute = false; // requiredSubgroupSizeStages has COMPUTE

  // Limits that shape kernels.
  uint64_t max_storage_buffer_range = 0;
  uint64_t max_memory_allocation_size = 0;
  uint64_t max_buffer_size = 0;
  uint64_t min_storage_buffer_offset_alignment = 0;
  uint64_t max_texel_buffer_elements = 0;
  uint64_t min_texel_buffer_offset_alignment = 0;
  uint32_t max_workgroup_count[3] = {0, 0, 0};
  uint32_t max_workgroup_size[3] = {0, 0, 0};
  uint32_t max_workgroup_invocations = 0;
  uint32_t max_shared_memory = 0;
  uint32_t max_push_constants = 0;
  float timestamp_period_ns = 0.0f;
  bool timestamps_on_compute = false;
  uint64_t device_local_bytes = 0;
  bool device_local_host_visible = false;  // unified memory (lavapipe, some iGPUs)

  // Optional capabilities the engine uses when present.
  bool push_descriptor = false;
  bool buffer_device_address = false;
  bool shader_int64 = false;
  bool shader_float64 = false;
  bool shader_float16 = false;
  bool shader_int8 = false;
  bool storage_8bit = false;
  bool storage_16bit = false;
  bool scalar_block_layout = false;
  bool synchronization2 = false;
  bool host_query_reset = false;
  bool atomic_float_add = false;
  // VK_NV_cooperative_matrix with 16 x 16 x 16 fp16 x fp16 -> fp32 fragments at subgroup
  // scope (NVIDIA). The KHR extension is not used: Debian 12's glslang 12 cannot compile
  // GL_KHR_cooperative_matrix, so AMD and Intel (RADV and ANV expose only KHR) take the
  // shared-memory path.
  bool cooperative_matrix_nv = false;

  // A device is usable when it has a compute queue, Vulkan 1.3 and synchronization2.
  uint32_t compute_queue_family = UINT32_MAX;
  bool usable = false;
  std::string unusable_reason;
};

const char* device_type_name(VkPhysicalDeviceType type);
std::string api_version_string(uint32_t version);

// Queries every physical device of `instance`.
std::vector<DeviceInfo> query_devices(VkInstance instance);

// Chooses a device: `selector` (an index or a case-insensitive name substring,
// usually from ICUBE_DEVICE) when given, else the best usable device type.
// Throws std::runtime_error naming the devices when nothing matches.
const DeviceInfo& select_device(const std::vector<DeviceInfo>& devices, const std::string& selector);

// Multi-line human-readable description used by `icube devices`.
std::string describe_device(const DeviceInfo& info);

}  // namespace icube::gpu
