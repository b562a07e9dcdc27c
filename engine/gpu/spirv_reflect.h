// Minimal SPIR-V reflection for compute shaders: workgroup size (literal or
// specialisation constants), descriptor bindings and the push-constant size.
//
// The dispatch helper checks every call against this, so a C++ push-constant
// struct or binding list that drifts from its shader fails loudly at the call
// instead of reading garbage on the GPU.
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace icube::gpu {

struct ReflectedBinding {
  uint32_t set = 0;
  uint32_t binding = 0;
  VkDescriptorType type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  std::string name;  // variable or block name, for error messages
};

struct ShaderReflection {
  uint32_t local_size[3] = {1, 1, 1};            // defaults as compiled
  int32_t local_size_spec_id[3] = {-1, -1, -1};  // spec constant id per axis, -1 = literal
  std::vector<ReflectedBinding> bindings;        // sorted by (set, binding)
  uint32_t push_constant_size = 0;               // bytes; 0 = no push constants
  std::vector<uint32_t> spec_ids;                // all specialisation constant ids
};

// Throws std::runtime_error on malformed or non-compute SPIR-V; `name` is used in messages.
ShaderReflection reflect_spirv(const uint32_t* words, size_t word_count, const std::string& name);

}  // namespace icube::gpu
