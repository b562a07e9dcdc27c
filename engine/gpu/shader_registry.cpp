#include "gpu/shader_registry.h"

#include <stdexcept>
#include <string>

namespace icube::gpu {

const EmbeddedShader& find_shader(std::string_view name) {
  for (size_t i = 0; i < kEmbeddedShaderCount; ++i)
    if (name == kEmbeddedShaders[i].name) return kEmbeddedShaders[i];
  std::string known;
  for (size_t i = 0; i < kEmbeddedShaderCount; ++i) known += std::string(i ? ", " : "") + kEmbeddedShaders[i].name;
  throw std::runtime_error("no embedded shader named '" + std::string(name) + "' (embedded: " + known + ")");
}

}  // namespace icube::gpu
