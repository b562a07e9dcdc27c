// LayerNorm-over-channels host module; see layer_norm.h.
#include "nn/layer_norm.h"

#include "gpu/context.h"
#include "shared/nn_params.h"

#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

LayerNorm::LayerNorm(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/layer_norm_channels")) {}

void LayerNorm::record(gpu::CommandList& cmd, const LayerNormShape& s, const gpu::Buffer& x, const gpu::Buffer& weight,
                       const gpu::Buffer& bias, const gpu::Buffer& y) {
  if (s.batch == 0 || s.channels == 0 || s.tokens == 0) return;
  const uint64_t elements = uint64_t{s.batch} * s.channels * s.tokens, bytes = elements * 4;
  if (bytes > ctx_.info().max_storage_buffer_range || elements > UINT32_MAX)
    throw std::invalid_argument("layer_norm: tensor of " + std::to_string(bytes) + " bytes exceeds one storage binding");
  auto fits = [](const char* what, uint64_t need, const gpu::Buffer& b) {
    if (need > b.size())
      throw std::invalid_argument(std::string("layer_norm: ") + what + " buffer holds " + std::to_string(b.size()) +
                                  " bytes, needs " + std::to_string(need));
  };
  fits("input", bytes, x);
  fits("output", bytes, y);
  fits("weight", uint64_t{s.channels} * 4, weight);
  fits("bias", uint64_t{s.channels} * 4, bias);
  const shader::LayerNormParams pc{s.batch, s.channels, static_cast<uint32_t>(s.tokens), s.eps};
  cmd.dispatch(program_, gpu::Threads{uint64_t{s.batch} * s.tokens}, pc,
               {x.binding(0, bytes), weight.binding(0, uint64_t{s.channels} * 4), bias.binding(0, uint64_t{s.channels} * 4),
                y.binding(0, bytes)});
}

}  // namespace icube::kernels::nn
