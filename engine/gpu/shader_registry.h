// SPIR-V of every shaders/<module>/*.comp, compiled at build time and embedded
// (cmake/IcubeShaders.cmake generates the table).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace icube::gpu {

struct EmbeddedShader {
  const char* name;  // folder-qualified name: "splat/blend" for shaders/splat/blend.comp
  const uint32_t* words;
  size_t word_count;
};

extern const EmbeddedShader kEmbeddedShaders[];
extern const size_t kEmbeddedShaderCount;

// Throws std::runtime_error listing the known names when `name` is not embedded.
const EmbeddedShader& find_shader(std::string_view name);

}  // namespace icube::gpu
