// Shared validated contexts whose storage bindings are capped (ContextOptions::max_storage_binding),
// so the windowed paths of data over one binding run on any device; one context per cap per test
// binary (creating a device is slow on lavapipe).
#pragma once

#include "gpu/context.h"

#include <cstdint>

namespace icube::test {

gpu::Context& capped_gpu_context(uint64_t max_storage_binding);

}  // namespace icube::test
