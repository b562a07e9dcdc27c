// Argument checks shared by the kernels/nn host modules: one-line
// std::invalid_argument messages naming the kernel and the tensor.
#pragma once

#include "gpu/buffer.h"
#include "gpu/context.h"

#include <cstdint>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

// `buffer` holds at least `bytes`.
inline void require_buffer(const char* kernel, const char* what, uint64_t bytes, const gpu::Buffer& buffer) {
  if (bytes > buffer.size())
    throw std::invalid_argument(std::string(kernel) + ": " + what + " buffer holds " + std::to_string(buffer.size()) +
                                " bytes, needs " + std::to_string(bytes));
}

// `elements` float32 fit one storage binding and 32-bit indices.
inline void require_one_binding(const gpu::Context& ctx, const char* kernel, const char* what, uint64_t elements) {
  if (elements * 4 > ctx.info().max_storage_buffer_range || elements > UINT32_MAX)
    throw std::invalid_argument(std::string(kernel) + ": " + what + " of " + std::to_string(elements * 4) +
                                " bytes exceeds one storage binding");
}

}  // namespace icube::kernels::nn
