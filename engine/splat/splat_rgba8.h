// Host module of shaders/splat/to_rgba8.comp: the splatting rasterizer's float
// RGBA image (SplatFrameBuffers::rgba, 16 bytes per pixel) as packed RGBA8
// words (R in the low byte, alpha 255) for a presenter that copies a buffer to
// an R8G8B8A8 image; channels floor(clamp(c, 0, 1)·255 + 0.5), NaN -> 0.
// Plus the plain-loop CPU reference.
// Tests: tests/splat/test_splat_rgba8.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "gpu/context.h"

#include <cstdint>
#include <vector>

namespace icube::splat {

class SplatToRgba8 {
 public:
  explicit SplatToRgba8(gpu::Context& ctx);
  // Records the conversion of `pixels` pixels of `image` into `out` (4 bytes each). The caller
  // orders the blend before it (compute -> compute) and its reads of `out` after.
  void record(gpu::CommandList& cmd, const gpu::Buffer& image, const gpu::Buffer& out, uint64_t pixels);

 private:
  gpu::Program& program_;
};

// The CPU reference: one word per pixel of `rgba` (4 floats each).
std::vector<uint32_t> splat_to_rgba8_cpu(const std::vector<float>& rgba);
uint8_t splat_channel8(float c);

}  // namespace icube::splat
