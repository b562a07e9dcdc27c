// Argument checks shared by the kernels/nn host modules: one-line
// std::invalid_argument messages naming the kernel and the tensor.
#pragma once

#include "gpu/buffer.h"
#include "gpu/context.h"

#include <algorithm>
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

// The device stores 16-bit values from shaders (storageBuffer16BitAccess), which `what` needs.
inline void require_f16_storage(const gpu::Context& ctx, const char* kernel, const char* what) {
  if (!ctx.info().storage_16bit)
    throw std::invalid_argument(std::string(kernel) + ": " + what + " needs 16-bit storage (storageBuffer16BitAccess), " +
                                "which this device lacks; keep it fp32 (--precision fp16-weights)");
}

// Tensors larger than one storage binding are processed in windows: a range
// [first, first + count) of float32 elements (or fp16: element_bytes 2) of a buffer bound from the binding-offset
// alignment at or below `first`; `offset` is `first`'s element index inside
// the binding (the kernels add it to their indices).
struct ElementWindow {
  gpu::BufferBinding binding;
  uint32_t offset = 0;
};

inline ElementWindow element_window(const gpu::Context& ctx, const gpu::Buffer& buf, uint64_t first, uint64_t count,
                                    uint64_t element_bytes = 4) {
  const uint64_t align = std::max<uint64_t>(4, ctx.info().min_storage_buffer_offset_alignment);
  const uint64_t byte = first * element_bytes, base = byte / align * align;
  return {buf.binding(base, byte - base + count * element_bytes), static_cast<uint32_t>((byte - base) / element_bytes)};
}

// The same window as a texel buffer (for kernels that fetch per-lane addresses as texels: a hardware
// gather on lavapipe instead of a per-lane load loop), from the texel-offset alignment at or below
// `first`: R32_SFLOAT, or R16_SFLOAT for fp16 elements (element_bytes 2; the fetch returns them as float).
inline ElementWindow texel_window(const gpu::Context& ctx, const gpu::Buffer& buf, uint64_t first, uint64_t count,
                                  uint64_t element_bytes = 4) {
  const uint64_t align = std::max<uint64_t>(4, ctx.info().min_texel_buffer_offset_alignment);
  const uint64_t byte = first * element_bytes, base = byte / align * align;
  const VkFormat format = element_bytes == 2 ? VK_FORMAT_R16_SFLOAT : VK_FORMAT_R32_SFLOAT;
  return {buf.texel_binding(format, base, byte - base + count * element_bytes),
          static_cast<uint32_t>((byte - base) / element_bytes)};
}

// Float32 elements one window may hold: the binding limit (`override_bytes`
// when non-zero, for tests; and maxTexelBufferElements) less one alignment,
// within 32-bit indices.
inline uint64_t window_elements(const gpu::Context& ctx, uint64_t override_bytes = 0) {
  uint64_t limit = override_bytes ? override_bytes : ctx.info().max_storage_buffer_range;
  // Windows may be bound as texel buffers too (texel_window): within maxTexelBufferElements as well.
  if (ctx.info().max_texel_buffer_elements > 0) limit = std::min(limit, ctx.info().max_texel_buffer_elements * 4);
  const uint64_t align = std::max<uint64_t>({4, ctx.info().min_storage_buffer_offset_alignment,
                                             ctx.info().min_texel_buffer_offset_alignment});
  return std::min<uint64_t>(limit > align ? (limit - align) / 4 : 0, UINT32_MAX / 2);
}

}  // namespace icube::kernels::nn
