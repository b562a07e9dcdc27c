// A compute pipeline made from one embedded shader plus specialisation
// constants, with its descriptor-set and pipeline layouts derived from SPIR-V
// reflection (push descriptors when the device has them).
#pragma once

#include "gpu/context.h"
#include "gpu/spirv_reflect.h"

#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace icube::gpu {

// Specialisation constants by id; all engine constants are 32-bit.
// Call sites label them: SpecConstants{}.set(0, sg /* local_size_x */).
struct SpecConstants {
  std::vector<std::pair<uint32_t, uint32_t>> values;

  SpecConstants& set(uint32_t id, uint32_t v);
  SpecConstants& set(uint32_t id, int32_t v) { return set(id, static_cast<uint32_t>(v)); }
  SpecConstants& set(uint32_t id, float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    return set(id, bits);
  }
  SpecConstants& set(uint32_t id, bool v) { return set(id, static_cast<uint32_t>(v ? 1 : 0)); }
  // Value for `id`, or `fallback` when not set.
  uint32_t get(uint32_t id, uint32_t fallback) const;
  std::string key() const;  // cache key, stable for equal sets
};

class Program {
 public:
  Program(Context& ctx, const std::string& shader_name, const SpecConstants& spec);
  ~Program();
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;

  const std::string& name() const { return name_; }
  VkPipeline pipeline() const { return pipeline_; }
  VkPipelineLayout layout() const { return layout_; }
  VkDescriptorSetLayout set_layout() const { return set_layout_; }
  bool uses_push_descriptors() const { return push_descriptors_; }
  const ShaderReflection& reflection() const { return reflection_; }
  // Workgroup size after specialisation.
  const uint32_t* local_size() const { return local_size_; }
  uint32_t invocations_per_group() const { return local_size_[0] * local_size_[1] * local_size_[2]; }
  // The subgroup size this pipeline is guaranteed to run with (0 = not pinned).
  uint32_t pinned_subgroup_size() const { return pinned_subgroup_size_; }

 private:
  Context& ctx_;
  std::string name_;
  ShaderReflection reflection_;
  uint32_t local_size_[3] = {1, 1, 1};
  uint32_t pinned_subgroup_size_ = 0;
  bool push_descriptors_ = false;
  VkShaderModule module_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

}  // namespace icube::gpu
