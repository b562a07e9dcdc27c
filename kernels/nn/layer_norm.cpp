// LayerNorm-over-channels host module; see layer_norm.h.
#include "kernels/nn/layer_norm.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

LayerNorm::LayerNorm(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/layer_norm")) {}

void LayerNorm::record(gpu::CommandList& cmd, const LayerNormShape& s, const gpu::Buffer& x, const gpu::Buffer& weight,
                       const gpu::Buffer& bias, const gpu::Buffer& y) {
  if (s.batch == 0 || s.channels == 0 || s.tokens == 0) return;
  const uint64_t elements = uint64_t{s.batch} * s.channels * s.tokens, bytes = elements * 4;
  require_one_binding(ctx_, "layer_norm", "tensor", elements);
  require_buffer("layer_norm", "input", bytes, x);
  const uint64_t y_bytes = elements * (s.f16_output ? 2 : 4);
  require_buffer("layer_norm", "output", y_bytes, y);
  require_buffer("layer_norm", "weight", uint64_t{s.channels} * 4, weight);
  require_buffer("layer_norm", "bias", uint64_t{s.channels} * 4, bias);
  const shader::LayerNormParams pc{s.batch, s.channels, static_cast<uint32_t>(s.tokens), s.eps};
  if (s.f16_output) require_f16_storage(ctx_, "layer_norm", "an fp16 output");
  cmd.dispatch(s.f16_output ? ctx_.program("nn/layer_norm_f16out") : program_, gpu::Threads{uint64_t{s.batch} * s.tokens}, pc,
               {x.binding(0, bytes), weight.binding(0, uint64_t{s.channels} * 4), bias.binding(0, uint64_t{s.channels} * 4),
                y.binding(0, y_bytes)});
}

}  // namespace icube::kernels::nn
