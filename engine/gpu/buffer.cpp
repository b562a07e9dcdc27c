#include "gpu/buffer.h"

#include "gpu/commands.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <numeric>
#include <utility>
#include <stdexcept>

namespace icube::gpu {
namespace {

uint32_t find_memory_type(const Context& ctx, uint32_t type_bits, MemoryUsage usage) {
  const VkPhysicalDeviceMemoryProperties& mp = ctx.memory_properties();
  // Ordered preferences: the first list entry any allowed type satisfies wins.
  std::vector<VkMemoryPropertyFlags> wants;
  const VkMemoryPropertyFlags dl = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, hv = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                              hc = VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, cached = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  switch (usage) {
    case MemoryUsage::DeviceLocal: wants = {dl | hv | hc, dl}; break;
    case MemoryUsage::Upload: wants = {hv | hc}; break;
    case MemoryUsage::Readback: wants = {hv | hc | cached, hv | hc}; break;
  }
  if (usage == MemoryUsage::DeviceLocal && !ctx.info().device_local_host_visible) wants = {dl};
  for (VkMemoryPropertyFlags want : wants)
    for (uint32_t t = 0; t < mp.memoryTypeCount; ++t)
      if ((type_bits & (1u << t)) && (mp.memoryTypes[t].propertyFlags & want) == want) return t;
  throw std::runtime_error("no Vulkan memory type fits this buffer on " + ctx.info().name);
}

std::string mib(VkDeviceSize bytes) { return std::to_string(bytes / (1024 * 1024)) + " MiB"; }

}  // namespace

Buffer::Buffer(Context& ctx, VkDeviceSize size, MemoryUsage usage, const std::string& name)
    : ctx_(&ctx), size_(size), name_(name.empty() ? "buffer" : name) {
  const DeviceInfo& info = ctx.info();
  if (size == 0) throw std::invalid_argument("buffer '" + name_ + "': size must be > 0");
  if (size > info.max_buffer_size || size > info.max_memory_allocation_size)
    throw OutOfMemoryError(VK_ERROR_OUT_OF_DEVICE_MEMORY,
                           "buffer '" + name_ + "' of " + mib(size) + " exceeds the device's max buffer/allocation size (" +
                               mib(std::min(info.max_buffer_size, info.max_memory_allocation_size)) + ")");
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = size;
  bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT |
              VK_BUFFER_USAGE_STORAGE_TEXEL_BUFFER_BIT |
              VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  if (info.buffer_device_address) bci.usage |= VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VK_CHECK(vkCreateBuffer(ctx.device(), &bci, nullptr, &buffer_));

  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(ctx.device(), buffer_, &req);
  VkMemoryAllocateFlagsInfo flags{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.pNext = info.buffer_device_address ? &flags : nullptr;
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = find_memory_type(ctx, req.memoryTypeBits, usage);
  VkResult r = vkAllocateMemory(ctx.device(), &mai, nullptr, &memory_);
  if (r != VK_SUCCESS) {
    release();
    if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY)
      throw OutOfMemoryError(r, "allocating " + mib(req.size) + " for buffer '" + name + "' failed: " + result_name(r));
    throw_vulkan_error(r, "vkAllocateMemory", __FILE__, __LINE__);
  }
  VK_CHECK(vkBindBufferMemory(ctx.device(), buffer_, memory_, 0));

  VkMemoryPropertyFlags props = ctx.memory_properties().memoryTypes[mai.memoryTypeIndex].propertyFlags;
  bool map = (props & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) &&
             !(usage == MemoryUsage::DeviceLocal && ctx.options().force_staging);
  if (map) VK_CHECK(vkMapMemory(ctx.device(), memory_, 0, VK_WHOLE_SIZE, 0, &mapped_));
  host_cached_ = map && (props & VK_MEMORY_PROPERTY_HOST_CACHED_BIT) != 0;
  if (info.buffer_device_address) {
    VkBufferDeviceAddressInfo ai{VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO};
    ai.buffer = buffer_;
    address_ = vkGetBufferDeviceAddress(ctx.device(), &ai);
  }
}

Buffer::~Buffer() { release(); }

void Buffer::release() {
  if (!ctx_) return;
  if (buffer_) {
    ctx_->release_views(buffer_);
    vkDestroyBuffer(ctx_->device(), buffer_, nullptr);
  }
  if (memory_) vkFreeMemory(ctx_->device(), memory_, nullptr);  // unmaps implicitly
  buffer_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  mapped_ = nullptr;
  host_cached_ = false;
}

Buffer::Buffer(Buffer&& o) noexcept { *this = std::move(o); }

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    release();
    ctx_ = o.ctx_;
    buffer_ = std::exchange(o.buffer_, VK_NULL_HANDLE);
    memory_ = std::exchange(o.memory_, VK_NULL_HANDLE);
    size_ = std::exchange(o.size_, 0);
    mapped_ = std::exchange(o.mapped_, nullptr);
    host_cached_ = std::exchange(o.host_cached_, false);
    address_ = std::exchange(o.address_, 0);
    name_ = std::move(o.name_);
  }
  return *this;
}

BufferBinding Buffer::binding(VkDeviceSize offset, VkDeviceSize range) const {
  if (offset + range > size_ || range == 0)
    throw std::out_of_range("buffer '" + name_ + "': binding [" + std::to_string(offset) + ", +" +
                            std::to_string(range) + ") outside its " + std::to_string(size_) + " bytes");
  return {buffer_, offset, range};
}

BufferBinding Buffer::texel_binding(VkFormat format, VkDeviceSize offset, VkDeviceSize range) const {
  BufferBinding b = binding(offset, range);
  b.texel_format = format;
  return b;
}

uint64_t aligned_element_unit(const DeviceInfo& info, uint64_t element_bytes) {
  const uint64_t align = std::max<uint64_t>(4, info.min_storage_buffer_offset_alignment);
  return align / std::gcd(align, std::max<uint64_t>(1, element_bytes));
}

std::vector<ElementWindow> storage_windows(const DeviceInfo& info, uint64_t element_count, uint32_t element_size,
                                           uint64_t multiple_of, uint64_t max_bytes) {
  uint64_t limit = info.max_storage_buffer_range;
  if (max_bytes) limit = std::min(limit, max_bytes);
  // Window length in elements: a multiple of the tile and of the offset alignment.
  uint64_t unit = std::lcm(std::max<uint64_t>(1, multiple_of), aligned_element_unit(info, element_size));
  uint64_t per_window = (limit / element_size) / unit * unit;
  if (per_window == 0) throw std::invalid_argument("storage_windows: tile does not fit one storage binding");
  std::vector<ElementWindow> out;
  for (uint64_t first = 0; first < element_count; first += per_window)
    out.push_back({first, std::min(per_window, element_count - first)});
  return out;
}

namespace {
constexpr VkDeviceSize kStagingChunk = 64ull << 20;
}

void ensure_capacity(Context& ctx, Buffer& b, VkDeviceSize bytes, const std::string& name, MemoryUsage usage) {
  bytes = std::max<VkDeviceSize>(bytes, 16);
  if (b.valid() && b.size() >= bytes) return;
  Buffer grown(ctx, bytes + bytes / 2, usage, name);
  ctx.retire(std::move(b));  // recorded commands may still use the outgrown one
  b = std::move(grown);
}

namespace {
std::atomic<uint64_t> g_bytes_to_device{0}, g_bytes_to_host{0};
}  // namespace

HostTransferBytes host_transfer_bytes() { return {g_bytes_to_device.load(), g_bytes_to_host.load()}; }

void upload(Context& ctx, const Buffer& dst, const void* src, size_t bytes, VkDeviceSize dst_offset) {
  if (dst_offset + bytes > dst.size())
    throw std::out_of_range("upload to '" + dst.name() + "' past its end");
  g_bytes_to_device += bytes;
  if (dst.mapped()) {
    std::memcpy(static_cast<char*>(dst.mapped()) + dst_offset, src, bytes);
    return;
  }
  Buffer staging(ctx, std::min<VkDeviceSize>(bytes, kStagingChunk), MemoryUsage::Upload, "staging-upload");
  for (size_t done = 0; done < bytes;) {
    size_t n = std::min<size_t>(bytes - done, kStagingChunk);
    std::memcpy(staging.mapped(), static_cast<const char*>(src) + done, n);
    ctx.submit_and_wait([&](CommandList& cmd) {
      cmd.copy_buffer(staging.binding(0, n), dst.binding(dst_offset + done, n));
      cmd.barrier(deps::kTransferToCompute);  // later kernels read what the copy wrote
    });
    done += n;
  }
}

void download(Context& ctx, const Buffer& src, void* dst, size_t bytes, VkDeviceSize src_offset) {
  if (src_offset + bytes > src.size())
    throw std::out_of_range("download from '" + src.name() + "' past its end");
  g_bytes_to_host += bytes;
  if (src.mapped() && src.host_cached()) {
    std::memcpy(dst, static_cast<const char*>(src.mapped()) + src_offset, bytes);
    return;
  }
  Buffer staging(ctx, std::min<VkDeviceSize>(bytes, kStagingChunk), MemoryUsage::Readback, "staging-download");
  for (size_t done = 0; done < bytes;) {
    size_t n = std::min<size_t>(bytes - done, kStagingChunk);
    ctx.submit_and_wait([&](CommandList& cmd) {
      cmd.copy_buffer(src.binding(src_offset + done, n), staging.binding(0, n));
      cmd.barrier(deps::kTransferToHost);  // make the copy visible to the mapped read below
    });
    std::memcpy(static_cast<char*>(dst) + done, staging.mapped(), n);
    done += n;
  }
}

}  // namespace icube::gpu
