// RMSNorm-over-channels host module; see rms_norm.h.
#include "kernels/nn/rms_norm.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

RmsNorm::RmsNorm(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/rms_norm")) {}

void RmsNorm::record(gpu::CommandList& cmd, const RmsNormShape& s, const gpu::Buffer& x, const gpu::Buffer& gamma,
                     const gpu::Buffer& y) {
  if (s.batch == 0 || s.channels == 0 || s.plane == 0) return;
  if (s.channels > NN_RMS_MAX_CHANNELS)
    throw std::invalid_argument("rms_norm: " + std::to_string(s.channels) + " channels exceed the " +
                                std::to_string(NN_RMS_MAX_CHANNELS) +
                                " one invocation may loop over (lavapipe's 65,535 loop iterations); reduce the channels");
  if (!(s.eps >= 0.0f)) throw std::invalid_argument("rms_norm: eps must be >= 0");
  const uint64_t per_item = uint64_t{s.channels} * s.plane, bytes = uint64_t{s.batch} * per_item * 4;
  require_buffer("rms_norm", "input", bytes, x);
  require_buffer("rms_norm", "output", bytes, y);
  require_buffer("rms_norm", "gamma", uint64_t{s.channels} * 4, gamma);
  shader::RmsNormParams pc{};
  pc.channels = s.channels;
  pc.flags = s.silu ? NN_RMS_FLAG_SILU : 0u;
  pc.eps = s.eps;
  pc.scale = static_cast<float>(std::sqrt(static_cast<double>(s.channels)));
  const gpu::BufferBinding gb = gamma.binding(0, uint64_t{s.channels} * 4);
  auto dispatch = [&](uint64_t first, uint64_t span, uint32_t batch, uint64_t pixels) {
    const ElementWindow xw = element_window(ctx_, x, first, span), yw = element_window(ctx_, y, first, span);
    pc.batch = batch;
    pc.pixels = static_cast<uint32_t>(pixels);
    pc.x_offset = xw.offset;
    pc.y_offset = yw.offset;
    cmd.dispatch(program_, gpu::Threads{uint64_t{batch} * pixels}, pc, {xw.binding, gb, yw.binding});
  };
  // Windows (disjoint outputs, no barrier): as many whole batch elements as fit; else pixel ranges of one
  // batch element, whose bindings span every channel of the range.
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  if (per_item <= fit) {
    if (s.plane > UINT32_MAX || per_item > UINT32_MAX) throw std::invalid_argument("rms_norm: the image is too large");
    pc.plane = static_cast<uint32_t>(s.plane);
    pc.batch_stride = static_cast<uint32_t>(per_item);
    const uint64_t items = std::min<uint64_t>(s.batch, fit / per_item);
    for (uint64_t b = 0; b < s.batch; b += items) {
      const uint64_t n = std::min<uint64_t>(items, s.batch - b);
      dispatch(b * per_item, n * per_item, static_cast<uint32_t>(n), s.plane);
    }
    return;
  }
  const uint64_t spread = (uint64_t{s.channels} - 1) * s.plane;  // from a pixel's first channel to its last
  if (spread >= fit)
    throw std::invalid_argument("rms_norm: " + std::to_string(s.channels) + " channels of " + std::to_string(s.plane) +
                                " pixels exceed one storage binding (" + std::to_string(fit * 4) +
                                " bytes per window); reduce the image size or the channels");
  pc.plane = static_cast<uint32_t>(s.plane);
  pc.batch_stride = 0;
  const uint64_t window = fit - spread;
  for (uint64_t b = 0; b < s.batch; ++b)
    for (uint64_t p0 = 0; p0 < s.plane; p0 += window) {
      const uint64_t n = std::min(window, s.plane - p0);
      dispatch(b * per_item + p0, spread + n, 1, n);
    }
}

}  // namespace icube::kernels::nn
