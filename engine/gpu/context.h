// The Vulkan compute context: instance, optional Khronos validation with a
// debug messenger, device selection, one compute queue, and a program cache.
//
// One Context per process is the normal case (device creation on lavapipe is
// slow); tests share one through tests/gpu_test_context.h.
#pragma once

#include "gpu/device_info.h"
#include "gpu/vk_check.h"

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace icube::gpu {

class Program;
class CommandList;
class Buffer;
struct SpecConstants;

struct ContextOptions {
  bool validation = false;     // enable VK_LAYER_KHRONOS_validation + messenger
  std::string device;          // index or name substring; empty = best
  bool force_staging = false;  // never map device-local memory, always go through staging (tests)
  bool disable_push_descriptors = false;  // use pooled descriptor sets even where push descriptors exist (tests)
  bool headless = true;        // no surface extensions (the viewer turns this off)
  // Caps maxStorageBufferRange as kernels see it (0: the device's): the windowed paths for data
  // over one binding run on devices whose bindings are GiBs (tests; lavapipe's is 128 MiB).
  uint64_t max_storage_binding = 0;
  std::vector<const char*> extra_instance_extensions;
  std::vector<const char*> extra_device_extensions;  // e.g. VK_KHR_swapchain for the viewer

  // Reads ICUBE_VALIDATION (1/0), ICUBE_DEVICE and ICUBE_MAX_STORAGE_BINDING (bytes; K/M/G suffixes).
  static ContextOptions from_env();
};

enum class MessageSeverity { Info, Warning, Error };

// Called for every validation/driver message of warning severity or above.
using MessageHandler = std::function<void(MessageSeverity, const std::string&)>;

class Context {
 public:
  explicit Context(const ContextOptions& options = ContextOptions::from_env());
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physical_device() const { return info_.handle; }
  VkDevice device() const { return device_; }
  VkQueue queue() const { return queue_; }
  uint32_t queue_family() const { return info_.compute_queue_family; }
  const DeviceInfo& info() const { return info_; }
  const std::vector<DeviceInfo>& all_devices() const { return devices_; }
  const ContextOptions& options() const { return options_; }
  bool validation_enabled() const { return validation_; }
  const VkPhysicalDeviceMemoryProperties& memory_properties() const { return memory_properties_; }

  // Subgroup size the kernels are specialised for: the device's reported size,
  // pinned per pipeline with requiredSubgroupSize when the device allows it.
  uint32_t subgroup_size() const { return info_.subgroup_size; }
  bool pins_subgroup_size() const;

  // Validation / driver messages. The handler runs on the thread that made the
  // Vulkan call; messages are also counted so callers can assert "none".
  void set_message_handler(MessageHandler handler);
  uint64_t message_count() const { return message_count_.load(); }

  // Records `record` into a one-time command buffer, submits it and waits.
  void submit_and_wait(const std::function<void(CommandList&)>& record);

  // A compute program for an embedded shader (folder-qualified name: "splat/blend" for
  // shaders/splat/blend.comp),
  // created on first use and cached by name and specialisation constants.
  Program& program(const std::string& shader_name, const SpecConstants& spec);
  Program& program(const std::string& shader_name);

  PFN_vkCmdPushDescriptorSetKHR push_descriptor_fn() const { return push_descriptor_fn_; }

  // Device-wide wait; used before destruction and by error paths.
  void wait_idle();

  // ---- resource lifetimes (deferred destruction, as Granite does) ----
  // Every CommandList holds a serial from open_command_list() until its destructor calls
  // close_command_list(); a list is destroyed only once its commands have completed (after
  // submit_and_wait's fence, or a caller's own fence, as the viewer's presenter does).
  uint64_t open_command_list();
  void close_command_list(uint64_t serial);
  // Destroys `b` once every command list open now has been closed: for buffers that recorded
  // (possibly pending) commands may still use, e.g. one outgrown by gpu::ensure_capacity.
  // Immediately when no list is open.
  void retire(Buffer&& b);
  // Buffers waiting in retire() (tests).
  size_t retired_count();

  // The texel-buffer view of bytes [offset, offset + range) of `buffer` as `format`, created on
  // first use and cached until the buffer is released (release_views). At most
  // kMaxViewsPerBuffer per buffer: older ones are retired like buffers.
  static constexpr size_t kMaxViewsPerBuffer = 16;
  VkBufferView texel_view(VkBuffer buffer, VkFormat format, VkDeviceSize offset, VkDeviceSize range);
  void release_views(VkBuffer buffer);  // Buffer::release, before the VkBuffer is destroyed
  size_t cached_view_count();           // tests

  // 256 zero bytes bound where gpu::null_binding() stands for an input the kernel does not
  // read in this configuration (commands.h).
  const Buffer& null_buffer() const { return *null_buffer_; }

 private:
  friend VkBool32 VKAPI_PTR context_debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                                    VkDebugUtilsMessageTypeFlagsEXT,
                                                    const VkDebugUtilsMessengerCallbackDataEXT*, void*);
  void create_instance();
  void create_device();
  void on_message(MessageSeverity severity, const std::string& text);

  ContextOptions options_;
  bool validation_ = false;
  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  std::vector<DeviceInfo> devices_;
  DeviceInfo info_;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool command_pool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkPhysicalDeviceMemoryProperties memory_properties_{};
  PFN_vkCmdPushDescriptorSetKHR push_descriptor_fn_ = nullptr;

  std::mutex message_mutex_;
  MessageHandler message_handler_;
  std::atomic<uint64_t> message_count_{0};

  std::mutex submit_mutex_;
  std::mutex program_mutex_;
  std::map<std::string, std::unique_ptr<Program>> programs_;

  struct Retired {
    uint64_t after = 0;  // destroy once every list with a serial below this is closed
    std::unique_ptr<Buffer> buffer;
    VkBufferView view = VK_NULL_HANDLE;
  };
  struct CachedView {
    VkFormat format;
    VkDeviceSize offset, range;
    VkBufferView view;
  };
  // Takes the retired resources no open list can use any more out of retired_ (under the lock).
  std::vector<Retired> take_collectable_locked();
  void destroy(std::vector<Retired>& done);
  std::mutex lifetime_mutex_;
  uint64_t next_serial_ = 1;
  std::vector<uint64_t> open_serials_;  // ascending
  std::vector<Retired> retired_;
  std::map<VkBuffer, std::vector<CachedView>> views_;  // per buffer, oldest first
  std::unique_ptr<Buffer> null_buffer_;
};

}  // namespace icube::gpu
