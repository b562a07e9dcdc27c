// The appearance model of shared/appearance_shading.h compiled as C++: its
// functions become members of `Shader`, whose member `P` plays the bound
// parameter buffer of shaders/appearance/shade.comp. Used by the CPU
// reference renderer and by the host's lighting set-up (ambient integrals of
// the sky), so host, reference and kernel evaluate one model.
#pragma once

#include "shared/appearance_params.h"

#include <glm/glm.hpp>

#include <cstdint>

namespace icube::render::shading {

using namespace glm;
using uint = std::uint32_t;

struct Shader {
  shader::AppearanceParams P{};
#include "shared/appearance_shading.h"
};

}  // namespace icube::render::shading
