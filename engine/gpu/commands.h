// Recording compute work: the typed dispatch helper, explicit synchronization2
// barriers, copies, fills and GPU timestamps.
//
// dispatch() takes *thread* counts, never group counts: it divides by the
// program's specialised workgroup size and, when a 1-D dispatch would need
// more groups than maxComputeWorkGroupCount[0] (65,535 on lavapipe), folds the
// groups into y (and z). Shaders recover the linear index with
// shaders/common/dispatch.glsl and bound-check against their element count.
//
// dispatch() never inserts barriers. Call sites say what depends on what:
//   cmd.dispatch(reduce, ...);
//   cmd.barrier(deps::kComputeToCompute);  // scan reads the partial sums
//   cmd.dispatch(scan, ...);
#pragma once

#include "gpu/buffer.h"
#include "gpu/program.h"

#include <initializer_list>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

namespace icube::gpu {

struct Threads {
  uint64_t x = 1;
  uint32_t y = 1;
  uint32_t z = 1;
};

struct GroupCounts {
  uint32_t x = 1, y = 1, z = 1;
};

// Group counts for `threads` on `program`, folded into 2-D/3-D when x would
// pass the device limit. Throws when even the folded grid does not fit.
GroupCounts group_counts(const DeviceInfo& info, const Program& program, Threads threads);

// ceil(a / b) and a rounded up to a multiple of b (b > 0).
constexpr uint64_t div_up(uint64_t a, uint64_t b) { return (a + b - 1) / b; }
constexpr uint64_t align_up(uint64_t a, uint64_t b) { return div_up(a, b) * b; }

// Thread count of a 1-D dispatch that gives each tile of a width x height image (tile_w x
// tile_h pixels, edge tiles partial) its own `threads_per_tile` invocations, tiles row-major:
// the kernel finds its tile as linear thread / threads_per_tile.
constexpr uint64_t tiled_threads(uint64_t width, uint64_t height, uint64_t tile_w, uint64_t tile_h,
                                 uint64_t threads_per_tile) {
  return div_up(width, tile_w) * div_up(height, tile_h) * threads_per_tile;
}

// A memory dependency between pipeline stages (synchronization2 terms).
struct MemoryDependency {
  VkPipelineStageFlags2 src_stage;
  VkAccessFlags2 src_access;
  VkPipelineStageFlags2 dst_stage;
  VkAccessFlags2 dst_access;
};

namespace deps {
// Kernel writes, later kernel reads (storage or texel-buffer fetches) or writes (RAW and WAW).
inline constexpr MemoryDependency kComputeToCompute{
    VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
    VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
    VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
// A copy, fill or update writes, kernels read (storage or texel-buffer fetches) or write.
inline constexpr MemoryDependency kTransferToCompute{
    VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
    VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
// Kernel writes, a copy reads or overwrites.
inline constexpr MemoryDependency kComputeToTransfer{
    VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
    VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT};
// Copy writes, a later copy reads or overwrites.
inline constexpr MemoryDependency kTransferToTransfer{
    VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
    VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT};
// Copy writes, the host reads mapped memory after the fence.
inline constexpr MemoryDependency kTransferToHost{VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                                                  VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                                                  VK_ACCESS_2_HOST_READ_BIT};
// Any device write, the host reads mapped memory after the fence.
inline constexpr MemoryDependency kAllToHost{VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                                             VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT};
}  // namespace deps

class GpuTimer;

class CommandList {
 public:
  // Holds a Context serial from here to its destruction, which must come after its commands
  // completed: buffers retired meanwhile (Context::retire) outlive it.
  CommandList(Context& ctx, VkCommandBuffer cmd);
  ~CommandList();
  CommandList(const CommandList&) = delete;
  CommandList& operator=(const CommandList&) = delete;

  VkCommandBuffer handle() const { return cmd_; }
  Context& context() const { return ctx_; }

  // Bindings in the shader's binding order, as a braced list or any contiguous range (a
  // std::vector or array built up by the caller); gpu::null_binding() for ones the kernel
  // does not access in this configuration.
  template <class PushConstants>
  void dispatch(Program& program, Threads threads, const PushConstants& pc, std::span<const BufferBinding> bindings) {
    static_assert(std::is_trivially_copyable_v<PushConstants>, "push constants must be plain data");
    dispatch_raw(program, threads, &pc, sizeof(PushConstants), bindings);
  }
  template <class PushConstants>
  void dispatch(Program& program, Threads threads, const PushConstants& pc, std::initializer_list<BufferBinding> bindings) {
    dispatch(program, threads, pc, std::span<const BufferBinding>(bindings.begin(), bindings.size()));
  }
  // For shaders without push constants.
  void dispatch(Program& program, Threads threads, std::initializer_list<BufferBinding> bindings) {
    dispatch_raw(program, threads, nullptr, 0, std::span<const BufferBinding>(bindings.begin(), bindings.size()));
  }
  void dispatch_raw(Program& program, Threads threads, const void* push, size_t push_size,
                    std::span<const BufferBinding> bindings);

  void barrier(const MemoryDependency& dep);
  void copy_buffer(const BufferBinding& src, const BufferBinding& dst);
  // Fills `dst` (offset and range multiples of 4) with a 32-bit pattern.
  void fill_buffer(const BufferBinding& dst, uint32_t value);
  // Writes `bytes` (a multiple of 4, at most 65,536) from host memory into `dst` in command order
  // (vkCmdUpdateBuffer; a transfer write, ordered with barriers like fill_buffer).
  void update_buffer(const BufferBinding& dst, const void* data, size_t bytes);
  void write_timestamp(GpuTimer& timer, uint32_t query, VkPipelineStageFlags2 stage);

 private:
  VkDescriptorSet allocate_set(Program& program);
  Context& ctx_;
  VkCommandBuffer cmd_;
  uint64_t serial_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;  // only without push descriptors
  std::vector<VkDescriptorPool> full_pools_;
};

// Named GPU intervals measured with timestamps. Usage:
//   GpuTimer t(ctx, 8);
//   ctx.submit_and_wait([&](CommandList& cmd) {
//     t.reset(cmd); int i = t.begin(cmd, "sort"); ...; t.end(cmd, i); });
//   t.milliseconds(i)
class GpuTimer {
 public:
  GpuTimer(Context& ctx, uint32_t max_intervals);
  ~GpuTimer();
  GpuTimer(const GpuTimer&) = delete;
  GpuTimer& operator=(const GpuTimer&) = delete;

  bool supported() const { return supported_; }
  void reset(CommandList& cmd);
  int begin(CommandList& cmd, const std::string& label);
  void end(CommandList& cmd, int interval);
  // Reads the results (after the submission finished); NaN when unsupported.
  double milliseconds(int interval);
  const std::string& label(int interval) const { return labels_.at(static_cast<size_t>(interval)); }
  int count() const { return static_cast<int>(labels_.size()); }
  VkQueryPool pool() const { return pool_; }

 private:
  Context& ctx_;
  VkQueryPool pool_ = VK_NULL_HANDLE;
  uint32_t capacity_ = 0;
  bool supported_ = false;
  std::vector<std::string> labels_;
};

}  // namespace icube::gpu
