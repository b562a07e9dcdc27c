// Inference BatchNorm (+ ReLU / SiLU) host module; see batch_norm.h.
#include "kernels/nn/batch_norm.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

static_assert(static_cast<uint32_t>(BatchNormActivation::none) == NN_BN_ACT_NONE);
static_assert(static_cast<uint32_t>(BatchNormActivation::relu) == NN_BN_ACT_RELU);
static_assert(static_cast<uint32_t>(BatchNormActivation::silu) == NN_BN_ACT_SILU);

BatchNormAffine batch_norm_affine(const std::vector<float>& weight, const std::vector<float>& bias,
                                  const std::vector<float>& running_mean, const std::vector<float>& running_var,
                                  double eps) {
  const size_t C = weight.size();
  if (bias.size() != C || running_mean.size() != C || running_var.size() != C)
    throw std::invalid_argument("batch_norm_affine: weight, bias, mean and var differ in length (" + std::to_string(C) +
                                ", " + std::to_string(bias.size()) + ", " + std::to_string(running_mean.size()) + ", " +
                                std::to_string(running_var.size()) + ")");
  BatchNormAffine a;
  a.scale.resize(C);
  a.shift.resize(C);
  for (size_t c = 0; c < C; ++c) {
    const double scale = static_cast<double>(weight[c]) / std::sqrt(static_cast<double>(running_var[c]) + eps);
    a.scale[c] = static_cast<float>(scale);
    a.shift[c] = static_cast<float>(static_cast<double>(bias[c]) - static_cast<double>(running_mean[c]) * scale);
  }
  return a;
}

BatchNorm::BatchNorm(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/batch_norm")) {}

void BatchNorm::record(gpu::CommandList& cmd, const BatchNormShape& s, const gpu::Buffer& x, const gpu::Buffer& scale,
                       const gpu::Buffer& shift, const gpu::Buffer& y, BatchNormActivation act) {
  const uint32_t activation = static_cast<uint32_t>(act);
  if (activation > NN_BN_ACT_SILU) throw std::invalid_argument("batch_norm: unknown activation " + std::to_string(activation));
  const uint64_t count = uint64_t{s.batch} * s.channels * s.spatial;
  if (count == 0) return;
  // The shader finds an element's channel from its spatial position first_spatial + i (both below 2^31).
  if (s.spatial > UINT32_MAX / 2)
    throw std::invalid_argument("batch_norm: " + std::to_string(s.spatial) + " elements per channel exceed 32-bit indices");
  require_buffer("batch_norm", "input", count * 4, x);
  require_buffer("batch_norm", "output", count * 4, y);
  require_buffer("batch_norm", "scale", uint64_t{s.channels} * 4, scale);
  require_buffer("batch_norm", "shift", uint64_t{s.channels} * 4, shift);
  require_one_binding(ctx_, "batch_norm", "the per-channel scale", s.channels);

  // Flat windows of consecutive elements (one when the tensor fits a binding); windows write disjoint ranges.
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  if (fit == 0) throw std::invalid_argument("batch_norm: the storage binding limit holds no element");
  shader::BatchNormParams pc{};
  pc.channels = s.channels;
  pc.spatial = static_cast<uint32_t>(s.spatial);
  pc.activation = activation;
  const gpu::BufferBinding scale_binding = scale.binding(0, uint64_t{s.channels} * 4);
  const gpu::BufferBinding shift_binding = shift.binding(0, uint64_t{s.channels} * 4);
  for (uint64_t first = 0; first < count; first += fit) {
    const uint64_t n = std::min(fit, count - first);
    const ElementWindow xw = element_window(ctx_, x, first, n);
    const ElementWindow yw = element_window(ctx_, y, first, n);
    pc.count = static_cast<uint32_t>(n);
    pc.first_channel = static_cast<uint32_t>(first / s.spatial % s.channels);
    pc.first_spatial = static_cast<uint32_t>(first % s.spatial);
    pc.x_offset = xw.offset;
    pc.y_offset = yw.offset;
    cmd.dispatch(program_, gpu::Threads{n}, pc, {xw.binding, scale_binding, shift_binding, yw.binding});
  }
}

}  // namespace icube::kernels::nn
