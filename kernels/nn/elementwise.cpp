// Element-wise and resampling host module; see elementwise.h.
#include "nn/elementwise.h"

#include "gpu/context.h"
#include "nn/buffer_checks.h"
#include "shared/nn_params.h"

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
  check_fits(ctx_, "elementwise input", a_count, a);
  if (b) check_fits(ctx_, "elementwise input", count, *b);
  check_fits(ctx_, "elementwise output", count, y);
  const shader::ElementwiseParams pc{static_cast<uint32_t>(count), op, channels, static_cast<uint32_t>(tokens)};
  cmd.dispatch(elementwise_, gpu::Threads{count}, pc,
               {a.binding(0, a_count * 4), b ? b->binding(0, count * 4) : gpu::null_binding(), y.binding(0, count * 4)});
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
  check_fits(ctx_, "resample input", in, x);
  check_fits(ctx_, "resample output", out, y);
  shader::ResampleParams pc{};
  pc.planes = planes;
  pc.size_x = sx;
  pc.size_y = sy;
  pc.size_z = sz;
  pc.op = op;
  cmd.dispatch(resample_, gpu::Threads{out}, pc, {x.binding(0, in * 4), y.binding(0, out * 4)});
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
