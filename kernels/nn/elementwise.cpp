// Element-wise and resampling host module; see elementwise.h.
#include "nn/elementwise.h"

#include "gpu/context.h"
#include "nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

namespace {

void check_fits(const gpu::Context& ctx, const char* what, uint64_t elements, const gpu::Buffer& b) {
  require_one_binding(ctx, "nn elementwise", what, elements);
  require_buffer("nn elementwise", what, elements * 4, b);
}

}  // namespace

Elementwise::Elementwise(gpu::Context& ctx)
    : ctx_(ctx), elementwise_(ctx.program("nn/elementwise")), resample_(ctx.program("nn/resample")) {}

void Elementwise::run(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& a, uint64_t a_count, const gpu::Buffer* b,
                      uint64_t count, uint32_t channels, uint64_t tokens, const gpu::Buffer& y) {
  if (count == 0) return;
  require_buffer("nn elementwise", "elementwise input", a_count * 4, a);
  if (b) require_buffer("nn elementwise", "elementwise input", count * 4, *b);
  require_buffer("nn elementwise", "elementwise output", count * 4, y);
  shader::ElementwiseParams pc{static_cast<uint32_t>(count), op, channels, static_cast<uint32_t>(tokens), 0, 0, 0, 0};
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  const bool fits = a_count <= fit && count <= fit;
  if (fits || op == NN_EW_GEGLU) {  // GEGLU is not windowed (8^3 tokens in the UNet): one binding
    if (!fits) check_fits(ctx_, "geglu input", a_count, a);
    cmd.dispatch(elementwise_, gpu::Threads{count}, pc,
                 {a.binding(0, a_count * 4), b ? b->binding(0, count * 4) : gpu::null_binding(), y.binding(0, count * 4)});
    return;
  }
  // SiLU and add: flat windows, element i of every operand in the same window.
  for (uint64_t first = 0; first < count; first += fit) {
    const uint64_t n = std::min(fit, count - first);
    const ElementWindow aw = element_window(ctx_, a, first, n), yw = element_window(ctx_, y, first, n);
    const ElementWindow bw = b ? element_window(ctx_, *b, first, n) : ElementWindow{gpu::null_binding(), 0};
    pc.count = static_cast<uint32_t>(n);
    pc.a_offset = aw.offset;
    pc.b_offset = bw.offset;
    pc.y_offset = yw.offset;
    cmd.dispatch(elementwise_, gpu::Threads{n}, pc, {aw.binding, bw.binding, yw.binding});
  }
}

void Elementwise::silu(gpu::CommandList& cmd, const gpu::Buffer& x, uint64_t count, const gpu::Buffer& y) {
  run(cmd, NN_EW_SILU, x, count, nullptr, count, 0, 0, y);
}

void Elementwise::add(gpu::CommandList& cmd, const gpu::Buffer& a, const gpu::Buffer& b, uint64_t count,
                      const gpu::Buffer& y) {
  run(cmd, NN_EW_ADD, a, count, &b, count, 0, 0, y);
}

void Elementwise::geglu(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t batch, uint32_t channels, uint64_t tokens,
                        const gpu::Buffer& y) {
  const uint64_t out = uint64_t{batch} * channels * tokens;
  if (uint64_t{channels} * tokens > UINT32_MAX) throw std::invalid_argument("nn geglu: too many elements per batch");
  run(cmd, NN_EW_GEGLU, x, 2 * out, nullptr, out, channels, tokens, y);
}

void Elementwise::resample(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& x, uint32_t planes, uint32_t sx,
                           uint32_t sy, uint32_t sz, const gpu::Buffer& y) {
  const uint64_t in = uint64_t{planes} * sx * sy * sz;
  const uint64_t out = op == NN_RS_AVGPOOL2 ? uint64_t{planes} * (sx / 2) * (sy / 2) * (sz / 2) : in * 8;
  if (out == 0) {
    if (op == NN_RS_AVGPOOL2 && in > 0)
      throw std::invalid_argument("nn avg_pool2: an axis of " + std::to_string(sx) + "x" + std::to_string(sy) + "x" +
                                  std::to_string(sz) + " is shorter than 2");
    return;
  }
  shader::ResampleParams pc{};
  pc.size_x = sx;
  pc.size_y = sy;
  pc.size_z = sz;
  pc.op = op;
  require_buffer("nn elementwise", "resample input", in * 4, x);
  require_buffer("nn elementwise", "resample output", out * 4, y);
  // Windows of whole planes (batch x channel volumes) when a tensor exceeds one binding.
  const uint64_t plane_in = in / planes, plane_out = out / planes;
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  const uint64_t per_window = std::min<uint64_t>(fit / std::max(plane_in, plane_out), planes);
  if (per_window == 0)
    throw std::invalid_argument("nn resample: one plane of " + std::to_string(std::max(plane_in, plane_out) * 4) +
                                " bytes exceeds one storage binding");
  for (uint64_t p0 = 0; p0 < planes; p0 += per_window) {
    const uint64_t n = std::min(per_window, planes - p0);
    const ElementWindow xw = element_window(ctx_, x, p0 * plane_in, n * plane_in);
    const ElementWindow yw = element_window(ctx_, y, p0 * plane_out, n * plane_out);
    pc.planes = static_cast<uint32_t>(n);
    pc.x_offset = xw.offset;
    pc.y_offset = yw.offset;
    cmd.dispatch(resample_, gpu::Threads{n * plane_out}, pc, {xw.binding, yw.binding});
  }
}

void Elementwise::avg_pool2(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy,
                            uint32_t sz, const gpu::Buffer& y) {
  resample(cmd, NN_RS_AVGPOOL2, x, planes, sx, sy, sz, y);
}

void Elementwise::upsample2(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy,
                            uint32_t sz, const gpu::Buffer& y) {
  resample(cmd, NN_RS_UPSAMPLE2, x, planes, sx, sy, sz, y);
}

}  // namespace icube::kernels::nn
