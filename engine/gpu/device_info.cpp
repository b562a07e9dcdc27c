#include "gpu/device_info.h"

#include <algorithm>
#include <cctype>
#include <sstream>
#include <stdexcept>

namespace icube::gpu {

const char* device_type_name(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
    default: return "other";
  }
}

std::string api_version_string(uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
         std::to_string(VK_API_VERSION_PATCH(v));
}

static bool has_extension(const std::vector<VkExtensionProperties>& exts, const char* name) {
  return std::any_of(exts.begin(), exts.end(),
                     [&](const VkExtensionProperties& e) { return std::string(e.extensionName) == name; });
}

// Whether the NV cooperative-matrix properties list 16 x 16 x 16 fp16 A/B with fp32 C/D at subgroup scope.
static bool has_f16_coopmat_16x16x16(VkInstance instance, VkPhysicalDevice pd) {
  auto props_fn = reinterpret_cast<PFN_vkGetPhysicalDeviceCooperativeMatrixPropertiesNV>(
      vkGetInstanceProcAddr(instance, "vkGetPhysicalDeviceCooperativeMatrixPropertiesNV"));
  if (!props_fn) return false;
  uint32_t count = 0;
  if (props_fn(pd, &count, nullptr) != VK_SUCCESS || count == 0) return false;
  std::vector<VkCooperativeMatrixPropertiesNV> props(count, {VK_STRUCTURE_TYPE_COOPERATIVE_MATRIX_PROPERTIES_NV});
  if (props_fn(pd, &count, props.data()) != VK_SUCCESS) return false;
  for (const VkCooperativeMatrixPropertiesNV& m : props)
    if (m.MSize == 16 && m.NSize == 16 && m.KSize == 16 && m.AType == VK_COMPONENT_TYPE_FLOAT16_NV &&
        m.BType == VK_COMPONENT_TYPE_FLOAT16_NV && m.CType == VK_COMPONENT_TYPE_FLOAT32_NV &&
        m.DType == VK_COMPONENT_TYPE_FLOAT32_NV && m.scope == VK_SCOPE_SUBGROUP_NV)
      return true;
  return false;
}

static DeviceInfo query_one(VkInstance instance, VkPhysicalDevice pd, uint32_t index) {
  DeviceInfo d;
  d.index = index;
  d.handle = pd;

  VkPhysicalDeviceProperties basic{};
  vkGetPhysicalDeviceProperties(pd, &basic);
  d.api_version = basic.apiVersion;
  d.name = basic.deviceName;
  d.type = basic.deviceType;
  d.vendor_id = basic.vendorID;
  d.device_id = basic.deviceID;
  if (basic.apiVersion < VK_API_VERSION_1_3) {
    d.unusable_reason = "needs Vulkan 1.3, device has " + api_version_string(basic.apiVersion);
  }

  // Vulkan 1.1+ property chains (valid on every 1.1 device; 1.3 structs only on 1.3).
  VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceSubgroupSizeControlProperties sizectl{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_SIZE_CONTROL_PROPERTIES};
  VkPhysicalDeviceMaintenance3Properties maint3{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES};
  VkPhysicalDeviceMaintenance4Properties maint4{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_4_PROPERTIES};
  VkPhysicalDeviceProperties2 props2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  props2.pNext = &driver;
  driver.pNext = &subgroup;
  subgroup.pNext = &maint3;
  if (basic.apiVersion >= VK_API_VERSION_1_3) {
    maint3.pNext = &sizectl;
    sizectl.pNext = &maint4;
  }
  vkGetPhysicalDeviceProperties2(pd, &props2);
  const VkPhysicalDeviceLimits& lim = props2.properties.limits;

  d.driver_name = driver.driverName;
  d.driver_info = driver.driverInfo;
  d.subgroup_size = subgroup.subgroupSize;
  d.subgroup_operations = (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) ? subgroup.supportedOperations : 0;
  d.min_subgroup_size = sizectl.minSubgroupSize ? sizectl.minSubgroupSize : subgroup.subgroupSize;
  d.max_subgroup_size = sizectl.maxSubgroupSize ? sizectl.maxSubgroupSize : subgroup.subgroupSize;
  d.required_size_in_compute = (sizectl.requiredSubgroupSizeStages & VK_SHADER_STAGE_COMPUTE_BIT) != 0;

  d.max_storage_buffer_range = lim.maxStorageBufferRange;
  d.max_memory_allocation_size = maint3.maxMemoryAllocationSize;
  d.max_buffer_size = basic.apiVersion >= VK_API_VERSION_1_3 ? maint4.maxBufferSize : maint3.maxMemoryAllocationSize;
  d.min_storage_buffer_offset_alignment = lim.minStorageBufferOffsetAlignment;
  d.max_texel_buffer_elements = lim.maxTexelBufferElements;
  d.min_texel_buffer_offset_alignment = lim.minTexelBufferOffsetAlignment;
  for (int i = 0; i < 3; ++i) {
    d.max_workgroup_count[i] = lim.maxComputeWorkGroupCount[i];
    d.max_workgroup_size[i] = lim.maxComputeWorkGroupSize[i];
  }
  d.max_workgroup_invocations = lim.maxComputeWorkGroupInvocations;
  d.max_shared_memory = lim.maxComputeSharedMemorySize;
  d.max_push_constants = lim.maxPushConstantsSize;
  d.timestamp_period_ns = lim.timestampPeriod;

  VkPhysicalDeviceMemoryProperties mem{};
  vkGetPhysicalDeviceMemoryProperties(pd, &mem);
  for (uint32_t h = 0; h < mem.memoryHeapCount; ++h)
    if (mem.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) d.device_local_bytes += mem.memoryHeaps[h].size;
  for (uint32_t t = 0; t < mem.memoryTypeCount; ++t) {
    VkMemoryPropertyFlags f = mem.memoryTypes[t].propertyFlags;
    if ((f & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) && (f & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) &&
        (f & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) &&
        mem.memoryHeaps[mem.memoryTypes[t].heapIndex].size >= d.device_local_bytes / 2)
      d.device_local_host_visible = true;
  }

  uint32_t qcount = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &qcount, nullptr);
  std::vector<VkQueueFamilyProperties> queues(qcount);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &qcount, queues.data());
  // Prefer a family with compute (graphics families are fine; they are usually the main queue).
  for (uint32_t q = 0; q < qcount; ++q) {
    if (queues[q].queueFlags & VK_QUEUE_COMPUTE_BIT) {
      d.compute_queue_family = q;
      d.timestamps_on_compute = queues[q].timestampValidBits > 0;
      break;
    }
  }
  if (d.compute_queue_family == UINT32_MAX && d.unusable_reason.empty()) d.unusable_reason = "no compute queue";

  uint32_t ecount = 0;
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &ecount, nullptr);
  std::vector<VkExtensionProperties> exts(ecount);
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &ecount, exts.data());
  d.push_descriptor = has_extension(exts, VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME);
  bool has_atomic_float = has_extension(exts, VK_EXT_SHADER_ATOMIC_FLOAT_EXTENSION_NAME);
  const bool has_coopmat_nv = has_extension(exts, VK_NV_COOPERATIVE_MATRIX_EXTENSION_NAME);

  if (basic.apiVersion >= VK_API_VERSION_1_3) {
    VkPhysicalDeviceShaderAtomicFloatFeaturesEXT atomic_float{
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_ATOMIC_FLOAT_FEATURES_EXT};
    VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    VkPhysicalDeviceVulkan11Features f11{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES};
    VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    f2.pNext = &f11;
    f11.pNext = &f12;
    f12.pNext = &f13;
    if (has_atomic_float) f13.pNext = &atomic_float;
    VkPhysicalDeviceCooperativeMatrixFeaturesNV coopmat{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_COOPERATIVE_MATRIX_FEATURES_NV};
    if (has_coopmat_nv) {
      coopmat.pNext = f2.pNext;
      f2.pNext = &coopmat;
    }
    vkGetPhysicalDeviceFeatures2(pd, &f2);
    d.shader_int64 = f2.features.shaderInt64;
    d.shader_float64 = f2.features.shaderFloat64;
    d.shader_float16 = f12.shaderFloat16;
    d.shader_int8 = f12.shaderInt8;
    d.storage_8bit = f12.storageBuffer8BitAccess;
    d.storage_16bit = f11.storageBuffer16BitAccess;
    d.scalar_block_layout = f12.scalarBlockLayout;
    d.buffer_device_address = f12.bufferDeviceAddress;
    d.host_query_reset = f12.hostQueryReset;
    d.synchronization2 = f13.synchronization2;
    d.subgroup_size_control = f13.subgroupSizeControl;
    d.compute_full_subgroups = f13.computeFullSubgroups;
    d.atomic_float_add = has_atomic_float && atomic_float.shaderBufferFloat32AtomicAdd;
    d.cooperative_matrix_nv = has_coopmat_nv && coopmat.cooperativeMatrix && f12.shaderFloat16 &&
                              has_f16_coopmat_16x16x16(instance, pd);
    if (!d.synchronization2 && d.unusable_reason.empty()) d.unusable_reason = "no synchronization2";
  }
  const VkSubgroupFeatureFlags needed = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT |
                                        VK_SUBGROUP_FEATURE_BALLOT_BIT | VK_SUBGROUP_FEATURE_SHUFFLE_BIT;
  if ((d.subgroup_operations & needed) != needed && d.unusable_reason.empty())
    d.unusable_reason = "compute shaders lack subgroup basic/arithmetic/ballot/shuffle";
  d.usable = d.unusable_reason.empty();
  return d;
}

std::vector<DeviceInfo> query_devices(VkInstance instance) {
  uint32_t count = 0;
  vkEnumeratePhysicalDevices(instance, &count, nullptr);
  std::vector<VkPhysicalDevice> handles(count);
  vkEnumeratePhysicalDevices(instance, &count, handles.data());
  std::vector<DeviceInfo> out;
  for (uint32_t i = 0; i < count; ++i) out.push_back(query_one(instance, handles[i], i));
  return out;
}

static int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
    default: return 4;
  }
}

static std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

static std::string device_list(const std::vector<DeviceInfo>& devices) {
  std::string s;
  for (const DeviceInfo& d : devices)
    s += " [" + std::to_string(d.index) + "] " + d.name + (d.usable ? "" : " (unusable: " + d.unusable_reason + ")") + ";";
  return s.empty() ? " none" : s;
}

const DeviceInfo& select_device(const std::vector<DeviceInfo>& devices, const std::string& selector) {
  if (devices.empty())
    throw std::runtime_error(
        "no Vulkan device found: install a driver (on Debian: apt-get install mesa-vulkan-drivers for lavapipe)");
  if (!selector.empty()) {
    bool numeric = std::all_of(selector.begin(), selector.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
    for (const DeviceInfo& d : devices) {
      bool match = numeric ? std::to_string(d.index) == selector : lower(d.name).find(lower(selector)) != std::string::npos;
      if (!match) continue;
      if (!d.usable) throw std::runtime_error("ICUBE_DEVICE=" + selector + " selects " + d.name + ", which " + d.unusable_reason);
      return d;
    }
    throw std::runtime_error("ICUBE_DEVICE=" + selector + " matches no device; devices:" + device_list(devices));
  }
  const DeviceInfo* best = nullptr;
  for (const DeviceInfo& d : devices)
    if (d.usable && (!best || type_rank(d.type) < type_rank(best->type))) best = &d;
  if (!best) throw std::runtime_error("no usable Vulkan device; devices:" + device_list(devices));
  return *best;
}

static std::string subgroup_ops_string(VkSubgroupFeatureFlags f) {
  std::string s;
  auto add = [&](VkSubgroupFeatureFlags bit, const char* name) {
    if (f & bit) s += std::string(s.empty() ? "" : " ") + name;
  };
  add(VK_SUBGROUP_FEATURE_BASIC_BIT, "basic");
  add(VK_SUBGROUP_FEATURE_VOTE_BIT, "vote");
  add(VK_SUBGROUP_FEATURE_ARITHMETIC_BIT, "arithmetic");
  add(VK_SUBGROUP_FEATURE_BALLOT_BIT, "ballot");
  add(VK_SUBGROUP_FEATURE_SHUFFLE_BIT, "shuffle");
  add(VK_SUBGROUP_FEATURE_SHUFFLE_RELATIVE_BIT, "shuffle_relative");
  add(VK_SUBGROUP_FEATURE_CLUSTERED_BIT, "clustered");
  add(VK_SUBGROUP_FEATURE_QUAD_BIT, "quad");
  return s.empty() ? "none" : s;
}

static std::string mib(uint64_t bytes) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(bytes % (1024 * 1024) ? 1 : 0);
  o << static_cast<double>(bytes) / (1024.0 * 1024.0) << " MiB";
  return o.str();
}

std::string describe_device(const DeviceInfo& d) {
  std::ostringstream o;
  auto yn = [](bool b) { return b ? "yes" : "no"; };
  o << "[" << d.index << "] " << d.name << "\n"
    << "    type                 " << device_type_name(d.type) << "\n"
    << "    driver               " << d.driver_name << " (" << d.driver_info << "), Vulkan "
    << api_version_string(d.api_version) << "\n"
    << "    usable               " << (d.usable ? "yes" : "no: " + d.unusable_reason) << "\n"
    << "    subgroup size        " << d.subgroup_size << " (min " << d.min_subgroup_size << ", max "
    << d.max_subgroup_size << ", size control " << yn(d.subgroup_size_control) << ", full subgroups "
    << yn(d.compute_full_subgroups) << ")\n"
    << "    subgroup ops         " << subgroup_ops_string(d.subgroup_operations) << "\n"
    << "    storage buffer range " << mib(d.max_storage_buffer_range) << " per binding (offset alignment "
    << d.min_storage_buffer_offset_alignment << " B)\n"
    << "    max allocation       " << mib(d.max_memory_allocation_size) << ", max buffer " << mib(d.max_buffer_size)
    << "\n"
    << "    workgroup count      " << d.max_workgroup_count[0] << " x " << d.max_workgroup_count[1] << " x "
    << d.max_workgroup_count[2] << "\n"
    << "    workgroup size       " << d.max_workgroup_size[0] << " x " << d.max_workgroup_size[1] << " x "
    << d.max_workgroup_size[2] << " (" << d.max_workgroup_invocations << " invocations)\n"
    << "    shared memory        " << d.max_shared_memory << " B; push constants " << d.max_push_constants << " B\n"
    << "    device-local memory  " << mib(d.device_local_bytes) << (d.device_local_host_visible ? " (host-visible)" : "")
    << "\n"
    << "    timestamps           " << (d.timestamps_on_compute ? "yes" : "no") << ", period " << d.timestamp_period_ns
    << " ns\n"
    << "    features used        push_descriptor=" << yn(d.push_descriptor) << " synchronization2=" << yn(d.synchronization2)
    << " subgroup_size_control=" << yn(d.subgroup_size_control) << " buffer_device_address="
    << yn(d.buffer_device_address) << " scalar_block_layout=" << yn(d.scalar_block_layout)
    << " int64=" << yn(d.shader_int64) << " float64=" << yn(d.shader_float64) << " float16=" << yn(d.shader_float16) << " int8=" << yn(d.shader_int8)
    << " storage8/16=" << yn(d.storage_8bit) << "/" << yn(d.storage_16bit) << " atomic_float_add="
    << yn(d.atomic_float_add) << " cooperative_matrix_nv=" << yn(d.cooperative_matrix_nv) << "\n";
  return o.str();
}

}  // namespace icube::gpu
