#include "gpu/commands.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace icube::gpu {

namespace {

// Bytes per texel of the formats texel bindings use.
uint64_t texel_format_bytes(VkFormat f) {
  switch (f) {
    case VK_FORMAT_R16_SFLOAT: return 2;
    case VK_FORMAT_R32_UINT: case VK_FORMAT_R32_SINT: case VK_FORMAT_R32_SFLOAT: return 4;
    case VK_FORMAT_R32G32_UINT: case VK_FORMAT_R32G32_SINT: case VK_FORMAT_R32G32_SFLOAT: return 8;
    case VK_FORMAT_R32G32B32A32_UINT: case VK_FORMAT_R32G32B32A32_SINT: case VK_FORMAT_R32G32B32A32_SFLOAT: return 16;
    default: throw std::invalid_argument("texel binding: unsupported format " + std::to_string(int(f)));
  }
}

}  // namespace

GroupCounts group_counts(const DeviceInfo& info, const Program& program, Threads threads) {
  const uint32_t* ls = program.local_size();
  auto ceil_div = div_up;
  uint64_t gx = ceil_div(threads.x, ls[0]);
  uint64_t gy = ceil_div(threads.y, ls[1]);
  uint64_t gz = ceil_div(threads.z, ls[2]);
  const uint32_t* max = info.max_workgroup_count;
  if (gx > max[0]) {
    if (gy != 1 || gz != 1)
      throw std::invalid_argument("dispatch of " + program.name() + ": " + std::to_string(gx) +
                                  " groups in x exceed the device limit and y/z are in use");
    // Fold: gx = fx * fy (* fz) with as little overshoot as possible.
    gy = ceil_div(gx, max[0]);
    if (gy > max[1]) {
      gz = ceil_div(gy, max[1]);
      gy = ceil_div(gy, gz);
    }
    gx = ceil_div(gx, gy * gz);
  }
  if (gx > max[0] || gy > max[1] || gz > max[2])
    throw std::invalid_argument("dispatch of " + program.name() + " needs " + std::to_string(gx) + " x " +
                                std::to_string(gy) + " x " + std::to_string(gz) + " groups, above the device limit");
  return {static_cast<uint32_t>(gx), static_cast<uint32_t>(gy), static_cast<uint32_t>(gz)};
}

CommandList::CommandList(Context& ctx, VkCommandBuffer cmd) : ctx_(ctx), cmd_(cmd), serial_(ctx.open_command_list()) {}

CommandList::~CommandList() {
  if (pool_) vkDestroyDescriptorPool(ctx_.device(), pool_, nullptr);
  for (VkDescriptorPool p : full_pools_) vkDestroyDescriptorPool(ctx_.device(), p, nullptr);
  ctx_.close_command_list(serial_);  // the buffers retired while it was open may go now
}

VkDescriptorSet CommandList::allocate_set(Program& program) {
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (!pool_) {
      VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1024},
                                      {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 256},
                                      {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 256},
                                      {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 256},
                                      {VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER, 256}};
      VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
      dpci.maxSets = 256;
      dpci.poolSizeCount = 5;
      dpci.pPoolSizes = sizes;
      VK_CHECK(vkCreateDescriptorPool(ctx_.device(), &dpci, nullptr, &pool_));
    }
    VkDescriptorSetLayout layout = program.set_layout();
    VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    ai.descriptorPool = pool_;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &layout;
    VkDescriptorSet set = VK_NULL_HANDLE;
    VkResult r = vkAllocateDescriptorSets(ctx_.device(), &ai, &set);
    if (r == VK_SUCCESS) return set;
    if (r != VK_ERROR_OUT_OF_POOL_MEMORY && r != VK_ERROR_FRAGMENTED_POOL) VK_CHECK(r);
    full_pools_.push_back(pool_);  // keep alive until the command list is done
    pool_ = VK_NULL_HANDLE;
  }
  throw std::runtime_error("descriptor allocation failed for " + program.name());
}

void CommandList::dispatch_raw(Program& program, Threads threads, const void* push, size_t push_size,
                               std::span<const BufferBinding> given) {
  const size_t binding_count = given.size();
  const ShaderReflection& refl = program.reflection();
  if (push_size != refl.push_constant_size)
    throw std::logic_error("dispatch of " + program.name() + ": push constants are " + std::to_string(push_size) +
                           " bytes, the shader declares " + std::to_string(refl.push_constant_size));
  if (binding_count != refl.bindings.size())
    throw std::logic_error("dispatch of " + program.name() + ": " + std::to_string(binding_count) +
                           " bindings given, the shader declares " + std::to_string(refl.bindings.size()));
  if (threads.x == 0 || threads.y == 0 || threads.z == 0) return;  // nothing to do
  const DeviceInfo& info = ctx_.info();
  GroupCounts groups = group_counts(info, program, threads);

  std::vector<VkDescriptorBufferInfo> infos(binding_count);
  std::vector<VkBufferView> views(binding_count, VK_NULL_HANDLE);
  std::vector<VkWriteDescriptorSet> writes(binding_count);
  for (size_t i = 0; i < binding_count; ++i) {
    const ReflectedBinding& rb = refl.bindings[i];
    const bool texel = rb.type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER || rb.type == VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER;
    BufferBinding b = given[i];
    if (b.null) {  // the context's zero buffer, as the shader declares the binding
      const VkFormat format = texel ? (b.texel_format != VK_FORMAT_UNDEFINED ? b.texel_format : VK_FORMAT_R32_UINT)
                                    : VK_FORMAT_UNDEFINED;
      b = format != VK_FORMAT_UNDEFINED ? ctx_.null_buffer().texel_binding(format) : ctx_.null_buffer().binding();
    }
    if (!b.buffer) throw std::logic_error("dispatch of " + program.name() + ": binding '" + rb.name + "' is empty");
    if (texel != (b.texel_format != VK_FORMAT_UNDEFINED))
      throw std::logic_error("dispatch of " + program.name() + ": binding '" + rb.name + "' " +
                             (texel ? "is a texel buffer and needs Buffer::texel_binding(format)"
                                    : "is not a texel buffer but was given a texel format"));
    if (texel) {
      const uint64_t texel_bytes = texel_format_bytes(b.texel_format);
      if (b.range % texel_bytes || b.range / texel_bytes > info.max_texel_buffer_elements)
        throw std::invalid_argument("dispatch of " + program.name() + ": texel binding '" + rb.name + "' spans " +
                                    std::to_string(b.range) + " bytes, not a multiple of its " +
                                    std::to_string(texel_bytes) + "-byte texels or above maxTexelBufferElements " +
                                    std::to_string(info.max_texel_buffer_elements));
      if (b.offset % info.min_texel_buffer_offset_alignment)
        throw std::invalid_argument("dispatch of " + program.name() + ": texel binding '" + rb.name + "' offset " +
                                    std::to_string(b.offset) + " is not aligned to " +
                                    std::to_string(info.min_texel_buffer_offset_alignment));
      views[i] = ctx_.texel_view(b.buffer, b.texel_format, b.offset, b.range);  // cached per buffer
      writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      writes[i].dstBinding = rb.binding;
      writes[i].descriptorCount = 1;
      writes[i].descriptorType = rb.type;
      writes[i].pTexelBufferView = &views[i];
      continue;
    }
    if (b.range > info.max_storage_buffer_range)
      throw std::invalid_argument("dispatch of " + program.name() + ": binding '" + rb.name + "' spans " +
                                  std::to_string(b.range) + " bytes, above maxStorageBufferRange " +
                                  std::to_string(info.max_storage_buffer_range) + "; split it with storage_windows()");
    if (b.offset % info.min_storage_buffer_offset_alignment)
      throw std::invalid_argument("dispatch of " + program.name() + ": binding '" + rb.name + "' offset " +
                                  std::to_string(b.offset) + " is not aligned to " +
                                  std::to_string(info.min_storage_buffer_offset_alignment));
    infos[i] = {b.buffer, b.offset, b.range};
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstBinding = rb.binding;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = rb.type;
    writes[i].pBufferInfo = &infos[i];
  }

  vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, program.pipeline());
  if (binding_count) {
    if (program.uses_push_descriptors()) {
      ctx_.push_descriptor_fn()(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, program.layout(), 0,
                                static_cast<uint32_t>(writes.size()), writes.data());
    } else {
      VkDescriptorSet set = allocate_set(program);
      for (VkWriteDescriptorSet& w : writes) w.dstSet = set;
      vkUpdateDescriptorSets(ctx_.device(), static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
      vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, program.layout(), 0, 1, &set, 0, nullptr);
    }
  }
  if (push_size)
    vkCmdPushConstants(cmd_, program.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, static_cast<uint32_t>(push_size), push);
  vkCmdDispatch(cmd_, groups.x, groups.y, groups.z);
}

void CommandList::barrier(const MemoryDependency& dep) {
  VkMemoryBarrier2 mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  mb.srcStageMask = dep.src_stage;
  mb.srcAccessMask = dep.src_access;
  mb.dstStageMask = dep.dst_stage;
  mb.dstAccessMask = dep.dst_access;
  VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  di.memoryBarrierCount = 1;
  di.pMemoryBarriers = &mb;
  vkCmdPipelineBarrier2(cmd_, &di);
}

void CommandList::copy_buffer(const BufferBinding& src, const BufferBinding& dst) {
  if (src.range != dst.range) throw std::logic_error("copy_buffer: source and destination ranges differ");
  VkBufferCopy region{src.offset, dst.offset, src.range};
  vkCmdCopyBuffer(cmd_, src.buffer, dst.buffer, 1, &region);
}

void CommandList::update_buffer(const BufferBinding& dst, const void* data, size_t bytes) {
  if (bytes == 0 || bytes % 4 || bytes > 65536 || bytes > dst.range || dst.offset % 4)
    throw std::invalid_argument("update_buffer: " + std::to_string(bytes) + " bytes at offset " + std::to_string(dst.offset) +
                                " (multiple of 4, at most 65536 and the binding's " + std::to_string(dst.range) + ")");
  vkCmdUpdateBuffer(cmd_, dst.buffer, dst.offset, bytes, data);
}

void CommandList::fill_buffer(const BufferBinding& dst, uint32_t value) {
  if (dst.offset % 4 || dst.range % 4) throw std::logic_error("fill_buffer: offset and range must be multiples of 4");
  vkCmdFillBuffer(cmd_, dst.buffer, dst.offset, dst.range, value);
}

void CommandList::write_timestamp(GpuTimer& timer, uint32_t query, VkPipelineStageFlags2 stage) {
  vkCmdWriteTimestamp2(cmd_, stage, timer.pool(), query);
}

GpuTimer::GpuTimer(Context& ctx, uint32_t max_intervals) : ctx_(ctx), capacity_(max_intervals) {
  supported_ = ctx.info().timestamps_on_compute && ctx.info().timestamp_period_ns > 0.0f;
  if (!supported_) return;
  VkQueryPoolCreateInfo qpci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  qpci.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qpci.queryCount = 2 * capacity_;
  VK_CHECK(vkCreateQueryPool(ctx.device(), &qpci, nullptr, &pool_));
}

GpuTimer::~GpuTimer() {
  if (pool_) vkDestroyQueryPool(ctx_.device(), pool_, nullptr);
}

void GpuTimer::reset(CommandList& cmd) {
  labels_.clear();
  if (supported_) vkCmdResetQueryPool(cmd.handle(), pool_, 0, 2 * capacity_);
}

int GpuTimer::begin(CommandList& cmd, const std::string& label) {
  if (labels_.size() >= capacity_) throw std::logic_error("GpuTimer: more intervals than its capacity");
  labels_.push_back(label);
  int i = static_cast<int>(labels_.size()) - 1;
  if (supported_) cmd.write_timestamp(*this, 2 * static_cast<uint32_t>(i), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
  return i;
}

void GpuTimer::end(CommandList& cmd, int interval) {
  if (supported_)
    cmd.write_timestamp(*this, 2 * static_cast<uint32_t>(interval) + 1, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
}

double GpuTimer::milliseconds(int interval) {
  if (!supported_) return std::numeric_limits<double>::quiet_NaN();
  uint64_t t[2] = {0, 0};
  VK_CHECK(vkGetQueryPoolResults(ctx_.device(), pool_, 2 * static_cast<uint32_t>(interval), 2, sizeof(t), t,
                                 sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  return static_cast<double>(t[1] - t[0]) * static_cast<double>(ctx_.info().timestamp_period_ns) * 1e-6;
}

}  // namespace icube::gpu
