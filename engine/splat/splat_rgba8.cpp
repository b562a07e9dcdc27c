#include "splat/splat_rgba8.h"

#include "shared/splat_params.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace icube::splat {

SplatToRgba8::SplatToRgba8(gpu::Context& ctx)
    : program_(ctx.program("splat/to_rgba8", gpu::SpecConstants{}.set(0, ctx.subgroup_size() * 8))) {}

void SplatToRgba8::record(gpu::CommandList& cmd, const gpu::Buffer& image, const gpu::Buffer& out, uint64_t pixels) {
  if (pixels == 0) return;
  if (pixels > UINT32_MAX) throw std::invalid_argument("splat_to_rgba8: too many pixels");
  shader::SplatToRgba8Params p{};
  p.pixels = static_cast<uint32_t>(pixels);
  cmd.dispatch(program_, {pixels}, p, {image.binding(0, pixels * 16), out.binding(0, pixels * 4)});
}

uint8_t splat_channel8(float c) {
  if (std::isnan(c)) return 0;
  return static_cast<uint8_t>(std::floor(std::clamp(c, 0.0f, 1.0f) * 255.0f + 0.5f));
}

std::vector<uint32_t> splat_to_rgba8_cpu(const std::vector<float>& rgba) {
  std::vector<uint32_t> out(rgba.size() / 4);
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = uint32_t{splat_channel8(rgba[4 * i])} | uint32_t{splat_channel8(rgba[4 * i + 1])} << 8 |
             uint32_t{splat_channel8(rgba[4 * i + 2])} << 16 | 0xff000000u;
  return out;
}

}  // namespace icube::splat
