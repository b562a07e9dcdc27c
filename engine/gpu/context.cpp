#include "gpu/context.h"

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "gpu/program.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace icube::gpu {

namespace {
const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

bool env_flag(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::strcmp(v, "0") != 0 && std::strcmp(v, "false") != 0;
}

bool instance_layer_present(const char* name) {
  uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  for (const VkLayerProperties& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

// "4096", "64K", "2M", "1G" (powers of 1024) → bytes; anything else names the variable.
uint64_t env_bytes(const char* name) {
  const char* v = std::getenv(name);
  if (!v || !*v) return 0;
  char* end = nullptr;
  const unsigned long long n = std::strtoull(v, &end, 10);
  uint64_t scale = 1;
  if (*end == 'K' || *end == 'k') scale = 1ull << 10, ++end;
  else if (*end == 'M' || *end == 'm') scale = 1ull << 20, ++end;
  else if (*end == 'G' || *end == 'g') scale = 1ull << 30, ++end;
  if (end == v || *end != '\0' || n == 0)
    throw std::invalid_argument(std::string(name) + "=" + v + ": expected a positive byte count such as 65536, 64K or 2M");
  return uint64_t(n) * scale;
}
}  // namespace

ContextOptions ContextOptions::from_env() {
  ContextOptions o;
  o.validation = env_flag("ICUBE_VALIDATION");
  if (const char* d = std::getenv("ICUBE_DEVICE")) o.device = d;
  o.max_storage_binding = env_bytes("ICUBE_MAX_STORAGE_BINDING");
  return o;
}

VkBool32 VKAPI_PTR context_debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                          VkDebugUtilsMessageTypeFlagsEXT /*types*/,
                                          const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  auto* ctx = static_cast<Context*>(user);
  MessageSeverity s = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? MessageSeverity::Error
                      : (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) ? MessageSeverity::Warning
                                                                                      : MessageSeverity::Info;
  ctx->on_message(s, data && data->pMessage ? data->pMessage : "(no message)");
  return VK_FALSE;
}

void Context::on_message(MessageSeverity severity, const std::string& text) {
  if (severity == MessageSeverity::Info) return;
  message_count_.fetch_add(1);
  std::lock_guard<std::mutex> lock(message_mutex_);
  if (message_handler_) {
    message_handler_(severity, text);
  } else {
    std::fprintf(stderr, "[vulkan %s] %s\n", severity == MessageSeverity::Error ? "error" : "warning", text.c_str());
  }
}

void Context::set_message_handler(MessageHandler handler) {
  std::lock_guard<std::mutex> lock(message_mutex_);
  message_handler_ = std::move(handler);
}

Context::Context(const ContextOptions& options) : options_(options) {
  try {
    create_instance();
    devices_ = query_devices(instance_);
    info_ = select_device(devices_, options_.device);
    if (options_.disable_push_descriptors) info_.push_descriptor = false;
    if (options_.max_storage_binding != 0)
      info_.max_storage_buffer_range = std::min(info_.max_storage_buffer_range, options_.max_storage_binding);
    create_device();
    null_buffer_ = std::make_unique<Buffer>(*this, 256, MemoryUsage::DeviceLocal, "null-binding");
    submit_and_wait([&](CommandList& cmd) { cmd.fill_buffer(null_buffer_->binding(), 0u); });
  } catch (...) {
    null_buffer_.reset();
    if (device_) vkDestroyDevice(device_, nullptr);
    if (messenger_) {
      auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
      destroy(instance_, messenger_, nullptr);
    }
    if (instance_) vkDestroyInstance(instance_, nullptr);
    throw;
  }
}

void Context::create_instance() {
  uint32_t loader_version = 0;
  if (vkEnumerateInstanceVersion(&loader_version) != VK_SUCCESS || loader_version < VK_API_VERSION_1_3)
    throw std::runtime_error("the Vulkan loader is older than 1.3 (found " + api_version_string(loader_version) + ")");

  validation_ = options_.validation;
  if (validation_ && !instance_layer_present(kValidationLayer))
    throw std::runtime_error(std::string(kValidationLayer) +
                             " was requested but is not installed (Debian: apt-get install vulkan-validationlayers)");

  std::vector<const char*> extensions = options_.extra_instance_extensions;
  std::vector<const char*> layers;
  if (validation_) {
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    layers.push_back(kValidationLayer);
  }

  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "InfiniCube-VK";
  app.applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0);
  app.pEngineName = "icube";
  app.apiVersion = VK_API_VERSION_1_3;

  // Messages during instance creation/destruction go to the same handler.
  VkDebugUtilsMessengerCreateInfoEXT mci{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  mci.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  mci.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  mci.pfnUserCallback = context_debug_callback;
  mci.pUserData = this;

  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pNext = validation_ ? &mci : nullptr;
  ici.pApplicationInfo = &app;
  ici.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  ici.enabledLayerCount = static_cast<uint32_t>(layers.size());
  ici.ppEnabledLayerNames = layers.data();
  VK_CHECK(vkCreateInstance(&ici, nullptr, &instance_));

  if (validation_) {
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
    VK_CHECK(create(instance_, &mci, nullptr, &messenger_));
  }
}

bool Context::pins_subgroup_size() const {
  return info_.subgroup_size_control && info_.required_size_in_compute &&
         info_.subgroup_size >= info_.min_subgroup_size && info_.subgroup_size <= info_.max_subgroup_size;
}

void Context::create_device() {
  const DeviceInfo& d = info_;
  float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = d.compute_queue_family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;

  // Enable only what the device has; kernels check DeviceInfo before relying on extras.
  VkPhysicalDeviceShaderAtomicFloatFeaturesEXT atomic_float{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_ATOMIC_FLOAT_FEATURES_EXT};
  atomic_float.shaderBufferFloat32AtomicAdd = d.atomic_float_add;
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  f13.synchronization2 = VK_TRUE;
  f13.subgroupSizeControl = d.subgroup_size_control;
  f13.computeFullSubgroups = d.compute_full_subgroups;
  f13.maintenance4 = VK_TRUE;
  VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  f12.shaderFloat16 = d.shader_float16;
  f12.shaderInt8 = d.shader_int8;
  f12.storageBuffer8BitAccess = d.storage_8bit;
  f12.scalarBlockLayout = d.scalar_block_layout;
  f12.bufferDeviceAddress = d.buffer_device_address;
  f12.hostQueryReset = d.host_query_reset;
  VkPhysicalDeviceVulkan11Features f11{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES};
  f11.storageBuffer16BitAccess = d.storage_16bit;
  VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  f2.features.shaderInt64 = d.shader_int64;
  f2.features.shaderFloat64 = d.shader_float64;
  f2.pNext = &f11;
  f11.pNext = &f12;
  f12.pNext = &f13;
  if (d.atomic_float_add) f13.pNext = &atomic_float;
  VkPhysicalDeviceCooperativeMatrixFeaturesNV coopmat{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_COOPERATIVE_MATRIX_FEATURES_NV};
  coopmat.cooperativeMatrix = VK_TRUE;
  if (d.cooperative_matrix_nv) {
    coopmat.pNext = f2.pNext;
    f2.pNext = &coopmat;
  }

  std::vector<const char*> extensions;
  if (d.push_descriptor) extensions.push_back(VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME);
  if (d.atomic_float_add) extensions.push_back(VK_EXT_SHADER_ATOMIC_FLOAT_EXTENSION_NAME);
  if (d.cooperative_matrix_nv) extensions.push_back(VK_NV_COOPERATIVE_MATRIX_EXTENSION_NAME);
  for (const char* e : options_.extra_device_extensions) extensions.push_back(e);

  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.pNext = &f2;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  dci.ppEnabledExtensionNames = extensions.data();
  VK_CHECK(vkCreateDevice(d.handle, &dci, nullptr, &device_));
  vkGetDeviceQueue(device_, d.compute_queue_family, 0, &queue_);
  vkGetPhysicalDeviceMemoryProperties(d.handle, &memory_properties_);
  if (d.push_descriptor)
    push_descriptor_fn_ =
        reinterpret_cast<PFN_vkCmdPushDescriptorSetKHR>(vkGetDeviceProcAddr(device_, "vkCmdPushDescriptorSetKHR"));
  if (!push_descriptor_fn_) info_.push_descriptor = false;

  VkCommandPoolCreateInfo cpci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cpci.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT | VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cpci.queueFamilyIndex = d.compute_queue_family;
  VK_CHECK(vkCreateCommandPool(device_, &cpci, nullptr, &command_pool_));
  VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VK_CHECK(vkCreateFence(device_, &fci, nullptr, &fence_));
}

Context::~Context() {
  if (device_) vkDeviceWaitIdle(device_);
  {
    std::vector<Retired> all;
    {
      std::lock_guard<std::mutex> lock(lifetime_mutex_);
      all.swap(retired_);
    }
    destroy(all);
  }
  null_buffer_.reset();
  for (auto& [buffer, list] : views_)
    for (const CachedView& v : list) vkDestroyBufferView(device_, v.view, nullptr);
  views_.clear();
  programs_.clear();
  if (fence_) vkDestroyFence(device_, fence_, nullptr);
  if (command_pool_) vkDestroyCommandPool(device_, command_pool_, nullptr);
  if (device_) vkDestroyDevice(device_, nullptr);
  if (messenger_) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    destroy(instance_, messenger_, nullptr);
  }
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

void Context::wait_idle() { VK_CHECK(vkDeviceWaitIdle(device_)); }

uint64_t Context::open_command_list() {
  std::lock_guard<std::mutex> lock(lifetime_mutex_);
  open_serials_.push_back(next_serial_);  // serials only grow: the list stays ascending
  return next_serial_++;
}

void Context::close_command_list(uint64_t serial) {
  std::vector<Retired> done;
  {
    std::lock_guard<std::mutex> lock(lifetime_mutex_);
    auto it = std::lower_bound(open_serials_.begin(), open_serials_.end(), serial);
    if (it != open_serials_.end() && *it == serial) open_serials_.erase(it);
    done = take_collectable_locked();
  }
  destroy(done);
}

void Context::retire(Buffer&& b) {
  if (!b.valid()) return;
  std::vector<Retired> done;
  {
    std::lock_guard<std::mutex> lock(lifetime_mutex_);
    Retired r;
    r.after = next_serial_;
    r.buffer = std::make_unique<Buffer>(std::move(b));
    retired_.push_back(std::move(r));
    done = take_collectable_locked();
  }
  destroy(done);
}

size_t Context::retired_count() {
  std::lock_guard<std::mutex> lock(lifetime_mutex_);
  return retired_.size();
}

std::vector<Context::Retired> Context::take_collectable_locked() {
  const uint64_t oldest_open = open_serials_.empty() ? next_serial_ : open_serials_.front();
  std::vector<Retired> done;
  auto keep = retired_.begin();
  for (auto it = retired_.begin(); it != retired_.end(); ++it) {
    if (it->after <= oldest_open)
      done.push_back(std::move(*it));
    else
      *keep++ = std::move(*it);
  }
  retired_.erase(keep, retired_.end());
  return done;
}

// Outside the lock: a Buffer's destructor calls release_views, which takes it.
void Context::destroy(std::vector<Retired>& done) {
  for (Retired& r : done) {
    if (r.view) vkDestroyBufferView(device_, r.view, nullptr);
    r.buffer.reset();
  }
  done.clear();
}

VkBufferView Context::texel_view(VkBuffer buffer, VkFormat format, VkDeviceSize offset, VkDeviceSize range) {
  std::vector<Retired> done;
  VkBufferView view = VK_NULL_HANDLE;
  {
    std::lock_guard<std::mutex> lock(lifetime_mutex_);
    std::vector<CachedView>& list = views_[buffer];
    for (const CachedView& v : list)
      if (v.format == format && v.offset == offset && v.range == range) return v.view;
    VkBufferViewCreateInfo vci{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
    vci.buffer = buffer;
    vci.format = format;
    vci.offset = offset;
    vci.range = range;
    VK_CHECK(vkCreateBufferView(device_, &vci, nullptr, &view));
    if (list.size() >= kMaxViewsPerBuffer) {  // a buffer bound with ever-changing ranges: retire the oldest view
      Retired r;
      r.after = next_serial_;
      r.view = list.front().view;
      retired_.push_back(std::move(r));
      list.erase(list.begin());
      done = take_collectable_locked();
    }
    list.push_back({format, offset, range, view});
  }
  destroy(done);
  return view;
}

void Context::release_views(VkBuffer buffer) {
  std::lock_guard<std::mutex> lock(lifetime_mutex_);
  auto it = views_.find(buffer);
  if (it == views_.end()) return;
  for (const CachedView& v : it->second) vkDestroyBufferView(device_, v.view, nullptr);
  views_.erase(it);
}

size_t Context::cached_view_count() {
  std::lock_guard<std::mutex> lock(lifetime_mutex_);
  size_t n = 0;
  for (const auto& [buffer, list] : views_) n += list.size();
  return n;
}

void Context::submit_and_wait(const std::function<void(CommandList&)>& record) {
  std::lock_guard<std::mutex> lock(submit_mutex_);
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = command_pool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VkCommandBuffer cb = VK_NULL_HANDLE;
  VK_CHECK(vkAllocateCommandBuffers(device_, &ai, &cb));
  struct FreeOnExit {
    VkDevice d;
    VkCommandPool p;
    VkCommandBuffer c;
    ~FreeOnExit() { vkFreeCommandBuffers(d, p, 1, &c); }
  } free_on_exit{device_, command_pool_, cb};

  CommandList list(*this, cb);
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VK_CHECK(vkBeginCommandBuffer(cb, &bi));
  record(list);
  // The one barrier not written at call sites: the submission's results are
  // read by the host through mapped memory once the fence signals.
  list.barrier(deps::kAllToHost);
  VK_CHECK(vkEndCommandBuffer(cb));

  VkCommandBufferSubmitInfo cbsi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  cbsi.commandBuffer = cb;
  VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  si.commandBufferInfoCount = 1;
  si.pCommandBufferInfos = &cbsi;
  VK_CHECK(vkResetFences(device_, 1, &fence_));
  VK_CHECK(vkQueueSubmit2(queue_, 1, &si, fence_));
  VK_CHECK(vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX));
}

Program& Context::program(const std::string& shader_name, const SpecConstants& spec) {
  std::lock_guard<std::mutex> lock(program_mutex_);
  std::string key = shader_name + spec.key();
  auto it = programs_.find(key);
  if (it != programs_.end()) return *it->second;
  auto p = std::make_unique<Program>(*this, shader_name, spec);
  Program& ref = *p;
  programs_.emplace(key, std::move(p));
  return ref;
}

Program& Context::program(const std::string& shader_name) { return program(shader_name, SpecConstants{}); }

}  // namespace icube::gpu
