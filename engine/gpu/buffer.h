// GPU buffers: move-only owners of a VkBuffer and its memory, plus the views
// kernels bind.
//
// Data larger than the device's maxStorageBufferRange (128 MiB on lavapipe)
// lives in one buffer and is bound as windows: storage_windows() splits an
// element range into aligned slices no larger than the limit, and kernels that
// accept large inputs (scan, reduce) loop over them on the host. Every buffer
// also has a device address when bufferDeviceAddress is present, for kernels
// that need to reach further than one binding.
#pragma once

#include "gpu/context.h"

#include <cstdint>
#include <string>
#include <vector>

namespace icube::gpu {

enum class MemoryUsage {
  DeviceLocal,  // fastest for kernels; mapped as well when the device has unified memory
  Upload,       // host-visible, host-coherent staging for CPU -> GPU
  Readback,     // host-visible, preferably cached, for GPU -> CPU
};

// A range of a buffer as bound to one descriptor.
struct BufferBinding {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceSize offset = 0;
  VkDeviceSize range = 0;  // bytes, never VK_WHOLE_SIZE (checked against maxStorageBufferRange)
  // Texel-buffer bindings (usamplerBuffer / utextureBuffer, imageBuffer): the view's format;
  // VK_FORMAT_UNDEFINED for storage and uniform buffers.
  VkFormat texel_format = VK_FORMAT_UNDEFINED;
  // gpu::null_binding(): no buffer; dispatch binds the context's zero buffer instead.
  bool null = false;
};

// For a binding the kernel does not access in this configuration (an absent optional input,
// an output a specialisation leaves out): dispatch binds 256 zero bytes (Context::null_buffer)
// as a storage buffer, or as a texel buffer of `texel_format` (R32_UINT when left undefined)
// where the shader declares one. Never for data a kernel reads or writes.
inline BufferBinding null_binding(VkFormat texel_format = VK_FORMAT_UNDEFINED) {
  BufferBinding b;
  b.texel_format = texel_format;
  b.null = true;
  return b;
}

class Buffer {
 public:
  Buffer() = default;
  Buffer(Context& ctx, VkDeviceSize size, MemoryUsage usage = MemoryUsage::DeviceLocal, const std::string& name = "");
  ~Buffer();
  Buffer(Buffer&& other) noexcept;
  Buffer& operator=(Buffer&& other) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return size_; }
  const std::string& name() const { return name_; }
  bool valid() const { return buffer_ != VK_NULL_HANDLE; }
  // Non-null when the memory is host-visible and persistently mapped.
  void* mapped() const { return mapped_; }
  // The mapping is host-cached: CPU reads are fast. A discrete GPU's host-visible device-local
  // memory (resizable BAR) is write-combined: writes stream, but each CPU read crosses the bus
  // uncached (a 3 MiB frame read took ~100 ms on an H200), so download() stages those.
  bool host_cached() const { return host_cached_; }
  VkDeviceAddress device_address() const { return address_; }

  BufferBinding binding() const { return {buffer_, 0, size_}; }
  // Bytes [offset, offset + range) of this buffer; throws if out of bounds.
  BufferBinding binding(VkDeviceSize offset, VkDeviceSize range) const;
  // The whole buffer / a range as a texel buffer of `format` (e.g. VK_FORMAT_R32_UINT): dispatch
  // takes the VkBufferView from the context's cache (Context::texel_view), made on first use
  // and destroyed with the buffer.
  BufferBinding texel_binding(VkFormat format) const { return {buffer_, 0, size_, format}; }
  BufferBinding texel_binding(VkFormat format, VkDeviceSize offset, VkDeviceSize range) const;

 private:
  void release();
  Context* ctx_ = nullptr;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  void* mapped_ = nullptr;
  bool host_cached_ = false;
  VkDeviceAddress address_ = 0;
  std::string name_;
};

// One window of an element array: elements [first, first + count).
struct ElementWindow {
  uint64_t first = 0;
  uint64_t count = 0;
};

// The fewest elements of `element_bytes` whose bytes are a multiple of
// minStorageBufferOffsetAlignment: a window whose first element is a multiple
// of it starts at an aligned offset.
uint64_t aligned_element_unit(const DeviceInfo& info, uint64_t element_bytes);

// Splits `element_count` elements of `element_size` bytes into windows that
// each fit one storage binding (<= maxStorageBufferRange, or `max_bytes` if
// smaller and non-zero) and start at offsets aligned to
// minStorageBufferOffsetAlignment. `multiple_of` keeps window sizes a multiple
// of a kernel's tile size (except the last window).
std::vector<ElementWindow> storage_windows(const DeviceInfo& info, uint64_t element_count, uint32_t element_size,
                                           uint64_t multiple_of = 1, uint64_t max_bytes = 0);

// Host <-> device copies. Mapped device-local buffers are written directly
// (unless ContextOptions::force_staging) and read directly when host-cached
// (integrated GPUs, lavapipe); others go through staging buffers in chunks, so
// a 300 MiB upload never needs 300 MiB of staging memory.
// Bytes moved between host and device by upload() and download() since the process started (all
// contexts, all threads), for measurements such as the sampler's host traffic per step.
struct HostTransferBytes {
  uint64_t to_device = 0, to_host = 0;
};
HostTransferBytes host_transfer_bytes();

void upload(Context& ctx, const Buffer& dst, const void* src, size_t bytes, VkDeviceSize dst_offset = 0);
void download(Context& ctx, const Buffer& src, void* dst, size_t bytes, VkDeviceSize src_offset = 0);

// Makes `b` hold at least `bytes` (at least 16): keeps it when it already does, else replaces it
// with a new buffer of 1.5 x `bytes`, so per-frame buffers that grow slowly are not reallocated
// every frame. The old contents are not kept; the old buffer is retired (Context::retire), so
// commands recorded with it but not yet complete stay valid.
void ensure_capacity(Context& ctx, Buffer& b, VkDeviceSize bytes, const std::string& name,
                     MemoryUsage usage = MemoryUsage::DeviceLocal);

template <class T>
Buffer upload_vector(Context& ctx, const std::vector<T>& data, const std::string& name = "") {
  Buffer b(ctx, data.empty() ? sizeof(T) : data.size() * sizeof(T), MemoryUsage::DeviceLocal, name);
  if (!data.empty()) upload(ctx, b, data.data(), data.size() * sizeof(T));
  return b;
}

template <class T>
std::vector<T> download_vector(Context& ctx, const Buffer& src, size_t count, VkDeviceSize src_offset = 0) {
  std::vector<T> out(count);
  if (count) download(ctx, src, out.data(), count * sizeof(T), src_offset);
  return out;
}

}  // namespace icube::gpu
