// Element-wise and resampling host module; see elementwise.h.
#include "nn/elementwise.h"

#include "gpu/context.h"
#include "nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

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
  if (a_count <= fit && count <= fit) {
    cmd.dispatch(elementwise_, gpu::Threads{count}, pc,
                 {a.binding(0, a_count * 4), b ? b->binding(0, count * 4) : gpu::null_binding(), y.binding(0, count * 4)});
    return;
  }
  if (op == NN_EW_GEGLU) {
    // Per batch element: the value half (a) and the gate half (b) of the input, each windowed with
    // the output as y = a * gelu(b).
    const uint64_t per = uint64_t{channels} * tokens, batch = count / per;
    for (uint64_t n = 0; n < batch; ++n)
      run_flat(cmd, NN_EW_GATE_GELU, a, 2 * n * per, &a, (2 * n + 1) * per, y, n * per, per);
    return;
  }
  run_flat(cmd, op, a, 0, b, 0, y, 0, count);
}

void Elementwise::run_flat(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& a, uint64_t a_first,
                           const gpu::Buffer* b, uint64_t b_first, const gpu::Buffer& y, uint64_t y_first,
                           uint64_t count) {
  // Element i of every operand in the same window; windows write disjoint outputs (no barrier).
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  shader::ElementwiseParams pc{0, op, 0, 0, 0, 0, 0, 0};
  for (uint64_t first = 0; first < count; first += fit) {
    const uint64_t n = std::min(fit, count - first);
    const ElementWindow aw = element_window(ctx_, a, a_first + first, n);
    const ElementWindow yw = element_window(ctx_, y, y_first + first, n);
    const ElementWindow bw = b ? element_window(ctx_, *b, b_first + first, n) : ElementWindow{gpu::null_binding(), 0};
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
  if (per_window == 0) {
    // A plane over one binding: slabs of whole x slices ([x][y][z], z fastest), each a smaller volume
    // of the same op: output slices [o0, o0 + k) from input slices [2 o0, 2 o0 + 2k) (pooling) or
    // [o0 / 2, ...) (upsampling).
    const bool pool = op == NN_RS_AVGPOOL2;
    const uint64_t yz_in = uint64_t{sy} * sz, yz_out = pool ? uint64_t{sy / 2} * (sz / 2) : 4 * yz_in;
    const uint64_t out_x = pool ? sx / 2 : 2 * uint64_t{sx};
    // k output slices need k * yz_out outputs and 2k (pooling) or k/2 (upsampling, k even) input slices.
    uint64_t k = pool ? std::min(fit / yz_out, fit / (2 * yz_in)) : std::min(fit / yz_out, 2 * (fit / yz_in)) / 2 * 2;
    if (k == 0)
      throw std::invalid_argument("nn resample: one x slice of " + std::to_string(sy) + "x" + std::to_string(sz) +
                                  " exceeds one storage binding (" + std::to_string(fit * 4) +
                                  " bytes): reduce the volume's y x z extent");
    for (uint64_t p0 = 0; p0 < planes; ++p0)
      for (uint64_t o0 = 0; o0 < out_x; o0 += k) {
        const uint64_t kk = std::min(k, out_x - o0);
        const uint64_t i0 = pool ? 2 * o0 : o0 / 2, ni = pool ? 2 * kk : kk / 2;
        const ElementWindow xw = element_window(ctx_, x, p0 * plane_in + i0 * yz_in, ni * yz_in);
        const ElementWindow yw = element_window(ctx_, y, p0 * plane_out + o0 * yz_out, kk * yz_out);
        pc.planes = 1;
        pc.size_x = static_cast<uint32_t>(ni);
        pc.x_offset = xw.offset;
        pc.y_offset = yw.offset;
        cmd.dispatch(resample_, gpu::Threads{kk * yz_out}, pc, {xw.binding, yw.binding});
      }
    return;
  }
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
