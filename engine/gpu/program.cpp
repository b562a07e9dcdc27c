#include "gpu/program.h"

#include "gpu/shader_registry.h"

#include <algorithm>
#include <stdexcept>

namespace icube::gpu {

SpecConstants& SpecConstants::set(uint32_t id, uint32_t v) {
  for (auto& [k, val] : values)
    if (k == id) {
      val = v;
      return *this;
    }
  values.emplace_back(id, v);
  std::sort(values.begin(), values.end());
  return *this;
}

uint32_t SpecConstants::get(uint32_t id, uint32_t fallback) const {
  for (const auto& [k, v] : values)
    if (k == id) return v;
  return fallback;
}

std::string SpecConstants::key() const {
  std::string k;
  for (const auto& [id, v] : values) {
    k.push_back('/');
    k.append(std::to_string(id));
    k.push_back('=');
    k.append(std::to_string(v));
  }
  return k;
}

Program::Program(Context& ctx, const std::string& shader_name, const SpecConstants& spec)
    : ctx_(ctx), name_(shader_name) {
  const EmbeddedShader& shader = find_shader(shader_name);
  reflection_ = reflect_spirv(shader.words, shader.word_count, shader_name);
  for (const auto& [id, v] : spec.values)
    if (std::find(reflection_.spec_ids.begin(), reflection_.spec_ids.end(), id) == reflection_.spec_ids.end())
      throw std::logic_error("shader " + shader_name + " has no specialisation constant " + std::to_string(id));
  for (int a = 0; a < 3; ++a) {
    int32_t sid = reflection_.local_size_spec_id[a];
    local_size_[a] = sid >= 0 ? spec.get(static_cast<uint32_t>(sid), reflection_.local_size[a]) : reflection_.local_size[a];
  }
  const DeviceInfo& info = ctx.info();
  if (invocations_per_group() > info.max_workgroup_invocations)
    throw std::logic_error("shader " + shader_name + ": workgroup of " + std::to_string(invocations_per_group()) +
                           " invocations exceeds the device limit " + std::to_string(info.max_workgroup_invocations));

  VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = shader.word_count * sizeof(uint32_t);
  smci.pCode = shader.words;
  VK_CHECK(vkCreateShaderModule(ctx.device(), &smci, nullptr, &module_));

  push_descriptors_ = info.push_descriptor && reflection_.bindings.size() <= 32;
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (const ReflectedBinding& b : reflection_.bindings)
    bindings.push_back({b.binding, b.type, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
  VkDescriptorSetLayoutCreateInfo dslci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dslci.flags = push_descriptors_ ? VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR : 0;
  dslci.bindingCount = static_cast<uint32_t>(bindings.size());
  dslci.pBindings = bindings.data();
  VK_CHECK(vkCreateDescriptorSetLayout(ctx.device(), &dslci, nullptr, &set_layout_));

  VkPushConstantRange pcr{VK_SHADER_STAGE_COMPUTE_BIT, 0, reflection_.push_constant_size};
  VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 1;
  plci.pSetLayouts = &set_layout_;
  plci.pushConstantRangeCount = reflection_.push_constant_size ? 1 : 0;
  plci.pPushConstantRanges = &pcr;
  VK_CHECK(vkCreatePipelineLayout(ctx.device(), &plci, nullptr, &layout_));

  std::vector<VkSpecializationMapEntry> entries;
  std::vector<uint32_t> data;
  for (const auto& [id, v] : spec.values) {
    entries.push_back({id, static_cast<uint32_t>(data.size() * 4), 4});
    data.push_back(v);
  }
  VkSpecializationInfo si{static_cast<uint32_t>(entries.size()), entries.data(), data.size() * 4, data.data()};

  VkPipelineShaderStageCreateInfo stage{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  stage.module = module_;
  stage.pName = "main";
  stage.pSpecializationInfo = entries.empty() ? nullptr : &si;
  // Pin the subgroup size to the one kernels are specialised for, and ask for
  // full subgroups when the workgroup width allows it, so subgroup-cooperative
  // kernels can rely on gl_SubgroupSize == Context::subgroup_size().
  VkPipelineShaderStageRequiredSubgroupSizeCreateInfo required{
      VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_REQUIRED_SUBGROUP_SIZE_CREATE_INFO};
  if (ctx.pins_subgroup_size()) {
    required.requiredSubgroupSize = ctx.subgroup_size();
    stage.pNext = &required;
    pinned_subgroup_size_ = ctx.subgroup_size();
    if (info.compute_full_subgroups && local_size_[0] % ctx.subgroup_size() == 0)
      stage.flags |= VK_PIPELINE_SHADER_STAGE_CREATE_REQUIRE_FULL_SUBGROUPS_BIT;
  }
  VkComputePipelineCreateInfo cpci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  cpci.stage = stage;
  cpci.layout = layout_;
  VK_CHECK(vkCreateComputePipelines(ctx.device(), VK_NULL_HANDLE, 1, &cpci, nullptr, &pipeline_));
}

Program::~Program() {
  VkDevice d = ctx_.device();
  if (pipeline_) vkDestroyPipeline(d, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(d, layout_, nullptr);
  if (set_layout_) vkDestroyDescriptorSetLayout(d, set_layout_, nullptr);
  if (module_) vkDestroyShaderModule(d, module_, nullptr);
}

}  // namespace icube::gpu
