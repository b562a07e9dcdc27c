// ConvTranspose2d host module; see conv_transpose2d.h.
#include "kernels/nn/conv_transpose2d.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

namespace {

uint32_t transposed_size(uint32_t in, uint32_t kernel, uint32_t stride, uint32_t padding) {
  if (in == 0) return 0;
  const int64_t n = (int64_t{in} - 1) * stride - 2 * int64_t{padding} + kernel;
  return n <= 0 ? 0u : static_cast<uint32_t>(std::min<int64_t>(n, UINT32_MAX));
}

}  // namespace

uint32_t ConvTranspose2dShape::out_height() const { return transposed_size(height, kernel_h, stride, padding); }
uint32_t ConvTranspose2dShape::out_width() const { return transposed_size(width, kernel_w, stride, padding); }

std::vector<float> pack_conv_transpose2d_weights(const std::vector<float>& w, uint32_t ci, uint32_t co, uint32_t kh,
                                                 uint32_t kw) {
  const uint64_t taps = uint64_t{kh} * kw, co_pad = gpu::align_up(co, NN_CONVT2D_CO_TILE);
  if (w.size() != uint64_t{ci} * co * taps)
    throw std::invalid_argument("conv_transpose2d: " + std::to_string(w.size()) + " weights for [" + std::to_string(ci) +
                                ", " + std::to_string(co) + ", " + std::to_string(kh) + ", " + std::to_string(kw) + "]");
  std::vector<float> out(static_cast<size_t>(ci * taps * co_pad), 0.0f);
  for (uint64_t i = 0; i < ci; ++i)
    for (uint64_t o = 0; o < co; ++o)
      for (uint64_t t = 0; t < taps; ++t)
        out[static_cast<size_t>((i * taps + t) * co_pad + o)] = w[static_cast<size_t>((i * co + o) * taps + t)];
  return out;
}

ConvTranspose2d::ConvTranspose2d(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/conv_transpose2d")) {}

void ConvTranspose2d::record(gpu::CommandList& cmd, const ConvTranspose2dShape& s, const gpu::Buffer& x,
                             const gpu::Buffer& w, const gpu::Buffer* bias, const gpu::Buffer& y) {
  if (s.stride == 0 || s.kernel_h == 0 || s.kernel_w == 0)
    throw std::invalid_argument("conv_transpose2d: stride and kernel must be positive");
  const uint32_t OH = s.out_height(), OW = s.out_width();
  if (s.batch == 0 || s.in_channels == 0 || s.out_channels == 0 || OH == 0 || OW == 0) return;
  const uint64_t in_plane = uint64_t{s.height} * s.width, out_plane = uint64_t{OH} * OW;
  const uint64_t limit = max_binding_bytes_ ? std::min(max_binding_bytes_, ctx_.info().max_storage_buffer_range)
                                            : ctx_.info().max_storage_buffer_range;
  const uint64_t x_bytes = uint64_t{s.batch} * s.in_channels * in_plane * 4;
  const uint64_t y_bytes = uint64_t{s.batch} * s.out_channels * out_plane * 4;
  const uint64_t taps = uint64_t{s.kernel_h} * s.kernel_w;
  const uint64_t co_vec4s = gpu::div_up(s.out_channels, NN_CONVT2D_CO_TILE) * (NN_CONVT2D_CO_TILE / 4);
  const uint64_t w_row_bytes = taps * co_vec4s * 16;  // one input channel's packed weights
  const uint64_t w_bytes = uint64_t{s.in_channels} * w_row_bytes;
  require_buffer("conv_transpose2d", "input", x_bytes, x);
  require_buffer("conv_transpose2d", "output", y_bytes, y);
  require_buffer("conv_transpose2d", "packed weights", w_bytes, w);
  if (bias) require_buffer("conv_transpose2d", "bias", uint64_t{s.out_channels} * 4, *bias);
  const uint64_t runs = gpu::div_up(gpu::div_up(OW, s.stride), NN_CONVT2D_XRUN);
  if (std::max(in_plane, uint64_t{OH} * s.stride * runs) > UINT32_MAX / 8 || out_plane > UINT32_MAX / 8)
    throw std::invalid_argument("conv_transpose2d: the image is too large (" + std::to_string(OH) + " x " +
                                std::to_string(OW) + " output pixels); reduce its size");

  shader::ConvTranspose2dParams pc{};
  pc.co_vec4s = static_cast<uint32_t>(co_vec4s);
  pc.in_h = s.height;
  pc.in_w = s.width;
  pc.out_h = OH;
  pc.out_w = OW;
  pc.kernel_h = s.kernel_h;
  pc.kernel_w = s.kernel_w;
  pc.stride = s.stride;
  pc.padding = s.padding;
  pc.runs = static_cast<uint32_t>(runs);
  pc.pixel_tiles = static_cast<uint32_t>(gpu::div_up(uint64_t{OH} * s.stride * runs, NN_CONVT2D_GROUP));
  pc.has_bias = bias ? 1u : 0u;
  const gpu::BufferBinding bb = bias ? bias->binding(0, uint64_t{s.out_channels} * 4) : gpu::null_binding();
  auto dispatch = [&](uint32_t batch, const gpu::BufferBinding& xb, const gpu::BufferBinding& wb, const gpu::BufferBinding& yb) {
    pc.batch = batch;
    pc.co_blocks = static_cast<uint32_t>(gpu::div_up(pc.co_count, NN_CONVT2D_CO_TILE));
    const uint64_t groups = uint64_t{pc.pixel_tiles} * pc.co_blocks * batch;
    cmd.dispatch(program_, gpu::Threads{groups * NN_CONVT2D_GROUP}, pc, {xb, wb, bb, yb});
  };
  // An invocation loops about ci_count * (1 + ceil(kh / s) * (1 + ceil(kw / s) * (1 + NN_CONVT2D_XRUN))) times;
  // lavapipe stops it after 65,535, so input channels go in windows below that.
  const uint64_t taps_y = gpu::div_up(s.kernel_h, s.stride), taps_x = gpu::div_up(s.kernel_w, s.stride);
  const uint64_t per_channel = 1 + taps_y * (1 + taps_x * (1 + NN_CONVT2D_XRUN));
  const uint64_t max_channels = std::max<uint64_t>(1, 60000 / per_channel);
  const uint64_t texel_limit = ctx_.info().max_texel_buffer_elements * 4;
  if (x_bytes <= std::min(limit, texel_limit) && y_bytes <= limit && w_bytes <= limit && s.in_channels <= max_channels) {
    pc.co_begin = 0;
    pc.co_count = s.out_channels;
    pc.ci_count = s.in_channels;
    pc.accumulate = 0;
    pc.x_offset = pc.y_offset = pc.w_offset = 0;
    pc.x_batch_stride = static_cast<uint32_t>(s.in_channels * in_plane);
    pc.y_batch_stride = static_cast<uint32_t>(s.out_channels * out_plane);
    dispatch(s.batch, x.texel_binding(VK_FORMAT_R32_SFLOAT, 0, x_bytes), w.binding(0, w_bytes), y.binding(0, y_bytes));
    return;
  }
  // Windows: one batch element at a time, output channels in whole 8-channel blocks, input channels as
  // many as fit (their planes and their packed weights), each bound at its offset aligned down (the rest
  // goes to *_offset).
  const uint64_t usable = window_elements(ctx_, max_binding_bytes_);
  const uint64_t ci_window = std::min({usable / in_plane, max_channels, usable / (w_row_bytes / 4)});
  const uint64_t co_window = usable / out_plane / NN_CONVT2D_CO_TILE * NN_CONVT2D_CO_TILE;
  if (ci_window == 0 || co_window == 0)
    throw std::invalid_argument("conv_transpose2d: one input channel (" + std::to_string(in_plane * 4) + " bytes, its packed weights " +
                                std::to_string(w_row_bytes) + ") or " + std::to_string(NN_CONVT2D_CO_TILE) +
                                " output channels (" + std::to_string(NN_CONVT2D_CO_TILE * out_plane * 4) +
                                " bytes) exceed one storage binding (" + std::to_string(limit) +
                                " bytes); reduce the image size or the output channels");
  pc.x_batch_stride = pc.y_batch_stride = 0;
  for (uint32_t b = 0; b < s.batch; ++b)
    for (uint64_t co0 = 0; co0 < s.out_channels; co0 += co_window) {
      pc.co_begin = static_cast<uint32_t>(co0);
      pc.co_count = static_cast<uint32_t>(std::min<uint64_t>(co_window, s.out_channels - co0));
      const ElementWindow yw = element_window(ctx_, y, (uint64_t{b} * s.out_channels + co0) * out_plane, uint64_t{pc.co_count} * out_plane);
      pc.y_offset = yw.offset;
      for (uint64_t ci0 = 0; ci0 < s.in_channels; ci0 += ci_window) {
        pc.ci_count = static_cast<uint32_t>(std::min<uint64_t>(ci_window, s.in_channels - ci0));
        pc.accumulate = ci0 > 0 ? 1u : 0u;
        if (ci0 > 0) cmd.barrier(gpu::deps::kComputeToCompute);  // later input windows read-modify-write y
        const ElementWindow xw = texel_window(ctx_, x, (uint64_t{b} * s.in_channels + ci0) * in_plane, uint64_t{pc.ci_count} * in_plane);
        pc.x_offset = xw.offset;
        // The packed rows of the window's channels (whole vec4s: the remainder below the aligned base is
        // a multiple of 16 bytes, as both the row start and any alignment >= 16 are).
        const ElementWindow ww = element_window(ctx_, w, ci0 * (w_row_bytes / 4), pc.ci_count * (w_row_bytes / 4));
        pc.w_offset = ww.offset / 4;
        dispatch(1, xw.binding, ww.binding, yw.binding);
      }
    }
}

}  // namespace icube::kernels::nn
