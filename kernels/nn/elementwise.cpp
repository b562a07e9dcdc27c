// Element-wise and resampling host module; see elementwise.h.
#include "kernels/nn/elementwise.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

Elementwise::Elementwise(gpu::Context& ctx)
    : ctx_(ctx), elementwise_(ctx.program("nn/elementwise")) {}

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

void Elementwise::gelu(gpu::CommandList& cmd, const gpu::Buffer& x, uint64_t count, const gpu::Buffer& y) {
  run(cmd, NN_EW_GELU, x, count, nullptr, count, 0, 0, y);
}

void Elementwise::relu(gpu::CommandList& cmd, const gpu::Buffer& x, uint64_t count, const gpu::Buffer& y) {
  run(cmd, NN_EW_RELU, x, count, nullptr, count, 0, 0, y);
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

}  // namespace icube::kernels::nn
