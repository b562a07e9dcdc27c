// Dense conv2d host module; see conv2d.h.
#include "kernels/nn/conv2d.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

uint32_t Conv2dShape::out_height() const {
  const int64_t n = int64_t{height} + 2 * int64_t{padding} - kernel_h;
  return n < 0 || stride == 0 ? 0u : static_cast<uint32_t>(n / stride + 1);
}

uint32_t Conv2dShape::out_width() const {
  const int64_t n = int64_t{width} + 2 * int64_t{padding} - kernel_w;
  return n < 0 || stride == 0 ? 0u : static_cast<uint32_t>(n / stride + 1);
}

std::vector<float> pack_conv2d_weights(const std::vector<float>& w, uint32_t co, uint32_t ci, uint32_t kh, uint32_t kw) {
  const uint64_t taps = uint64_t{kh} * kw, co_pad = gpu::align_up(co, NN_CONV_CO_TILE);
  if (w.size() != uint64_t{co} * ci * taps)
    throw std::invalid_argument("conv2d: " + std::to_string(w.size()) + " weights for [" + std::to_string(co) + ", " +
                                std::to_string(ci) + ", " + std::to_string(kh) + ", " + std::to_string(kw) + "]");
  std::vector<float> out(static_cast<size_t>(ci * taps * co_pad), 0.0f);
  for (uint64_t o = 0; o < co; ++o)
    for (uint64_t i = 0; i < ci; ++i)
      for (uint64_t t = 0; t < taps; ++t) out[static_cast<size_t>((i * taps + t) * co_pad + o)] = w[static_cast<size_t>((o * ci + i) * taps + t)];
  return out;
}

Conv2d::Conv2d(gpu::Context& ctx) : ctx_(ctx) { ctx_.program("nn/conv2d"); }

void Conv2d::record(gpu::CommandList& cmd, const Conv2dShape& s, const gpu::Buffer& x, const gpu::Buffer& w,
                    const gpu::Buffer* bias, const gpu::Buffer& y) {
  if (s.stride == 0 || s.kernel_h == 0 || s.kernel_w == 0) throw std::invalid_argument("conv2d: stride and kernel must be positive");
  const uint32_t OH = s.out_height(), OW = s.out_width();
  if (s.batch == 0 || s.in_channels == 0 || s.out_channels == 0 || OH == 0 || OW == 0) return;
  const uint64_t in_plane = uint64_t{s.height} * s.width, out_plane = uint64_t{OH} * OW;
  const uint64_t limit = max_binding_bytes_ ? max_binding_bytes_ : ctx_.info().max_storage_buffer_range;
  const uint64_t x_bytes = uint64_t{s.batch} * s.in_channels * in_plane * 4;
  const uint64_t y_bytes = uint64_t{s.batch} * s.out_channels * out_plane * 4;
  const uint64_t taps = uint64_t{s.kernel_h} * s.kernel_w;
  const uint64_t co_vec4s = gpu::div_up(s.out_channels, NN_CONV_CO_TILE) * (NN_CONV_CO_TILE / 4);
  const uint64_t w_bytes = uint64_t{s.in_channels} * taps * co_vec4s * 16;
  require_buffer("conv2d", "input", x_bytes, x);
  require_buffer("conv2d", "output", y_bytes, y);
  require_buffer("conv2d", "packed weights", w_bytes, w);
  if (bias) require_buffer("conv2d", "bias", uint64_t{s.out_channels} * 4, *bias);
  if (w_bytes > ctx_.info().max_storage_buffer_range)
    throw std::invalid_argument("conv2d: the packed weights (" + std::to_string(w_bytes) + " bytes) exceed one storage binding");
  if (std::max(in_plane, out_plane) > UINT32_MAX / 8) throw std::invalid_argument("conv2d: the image is too large");

  shader::Conv2dParams pc{};
  pc.in_channels = s.in_channels;
  pc.co_vec4s = static_cast<uint32_t>(co_vec4s);
  pc.in_h = s.height;
  pc.in_w = s.width;
  pc.out_h = OH;
  pc.out_w = OW;
  pc.kernel_h = s.kernel_h;
  pc.kernel_w = s.kernel_w;
  pc.stride = s.stride;
  pc.padding = s.padding;
  pc.pixel_tiles = static_cast<uint32_t>(gpu::div_up(uint64_t{OH} * gpu::div_up(OW, NN_CONV2D_XRUN), NN_CONV2D_GROUP));
  pc.has_bias = bias ? 1u : 0u;
  gpu::Program& prog = ctx_.program("nn/conv2d");
  const gpu::BufferBinding wb = w.binding(0, w_bytes);
  const gpu::BufferBinding bb = bias ? bias->binding(0, uint64_t{s.out_channels} * 4) : gpu::null_binding();
  auto dispatch = [&](uint32_t batch, const gpu::BufferBinding& xb, const gpu::BufferBinding& yb) {
    pc.batch = batch;
    pc.co_blocks = static_cast<uint32_t>(gpu::div_up(pc.co_count, NN_CONV_CO_TILE));
    const uint64_t groups = uint64_t{pc.pixel_tiles} * pc.co_blocks * batch;
    cmd.dispatch(prog, gpu::Threads{groups * NN_CONV2D_GROUP}, pc, {xb, wb, bb, yb});
  };
  // An invocation loops about ci_count * (1 + kh * (1 + kw * (1 + NN_CONV2D_XRUN))) times (counting the run's
  // loop, which need not unroll); lavapipe stops it after 65,535, so input channels go in windows below that.
  const uint64_t per_channel = 1 + uint64_t{s.kernel_h} * (1 + uint64_t{s.kernel_w} * (1 + NN_CONV2D_XRUN));
  const uint64_t max_channels = std::max<uint64_t>(1, 60000 / per_channel);
  const uint64_t texel_limit = ctx_.info().max_texel_buffer_elements * 4;
  if (x_bytes <= std::min(limit, texel_limit) && y_bytes <= limit && s.in_channels <= max_channels) {
    pc.co_begin = 0;
    pc.co_count = s.out_channels;
    pc.ci_begin = 0;
    pc.ci_count = s.in_channels;
    pc.accumulate = 0;
    pc.x_offset = pc.y_offset = 0;
    pc.x_batch_stride = static_cast<uint32_t>(s.in_channels * in_plane);
    pc.y_batch_stride = static_cast<uint32_t>(s.out_channels * out_plane);
    dispatch(s.batch, x.texel_binding(VK_FORMAT_R32_SFLOAT, 0, x_bytes), y.binding(0, y_bytes));
    return;
  }
  // Windows: one batch element at a time, output channels in whole 8-channel blocks, input channels as
  // many as fit, each bound at its offset aligned down (the rest goes to *_offset).
  const uint64_t usable = window_elements(ctx_, max_binding_bytes_);
  const uint64_t ci_window = std::min(usable / in_plane, max_channels);
  const uint64_t co_window = usable / out_plane / NN_CONV_CO_TILE * NN_CONV_CO_TILE;
  if (ci_window == 0 || co_window == 0)
    throw std::invalid_argument("conv2d: " + std::to_string(NN_CONV_CO_TILE) + " channels of a " + std::to_string(s.height) +
                                " x " + std::to_string(s.width) + " image exceed one storage binding (" + std::to_string(limit) +
                                " bytes)");
  pc.x_batch_stride = pc.y_batch_stride = 0;
  for (uint32_t b = 0; b < s.batch; ++b)
    for (uint64_t co0 = 0; co0 < s.out_channels; co0 += co_window) {
      pc.co_begin = static_cast<uint32_t>(co0);
      pc.co_count = static_cast<uint32_t>(std::min<uint64_t>(co_window, s.out_channels - co0));
      const ElementWindow yw = element_window(ctx_, y, (uint64_t{b} * s.out_channels + co0) * out_plane, uint64_t{pc.co_count} * out_plane);
      pc.y_offset = yw.offset;
      for (uint64_t ci0 = 0; ci0 < s.in_channels; ci0 += ci_window) {
        pc.ci_begin = static_cast<uint32_t>(ci0);
        pc.ci_count = static_cast<uint32_t>(std::min<uint64_t>(ci_window, s.in_channels - ci0));
        pc.accumulate = ci0 > 0 ? 1u : 0u;
        if (ci0 > 0) cmd.barrier(gpu::deps::kComputeToCompute);  // later input windows read-modify-write y
        const ElementWindow xw = texel_window(ctx_, x, (uint64_t{b} * s.in_channels + ci0) * in_plane, uint64_t{pc.ci_count} * in_plane);
        pc.x_offset = xw.offset;
        dispatch(1, xw.binding, yw.binding);
      }
    }
}

}  // namespace icube::kernels::nn
