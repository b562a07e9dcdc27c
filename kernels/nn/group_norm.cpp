// GroupNorm host module; see group_norm.h.
#include "nn/group_norm.h"

#include "gpu/context.h"
#include "nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

namespace {

// Partials per (batch, group): enough threads to fill a device, each with at least ~64 elements,
// and at most 32,768 elements per partial (lavapipe stops an invocation after 65,535 loop iterations).
uint32_t chunks_for(const GroupNormShape& s) {
  const uint64_t n = uint64_t{s.channels} / s.groups * s.spatial;
  return static_cast<uint32_t>(std::max<uint64_t>(std::clamp<uint64_t>(n / 64, 1, 256), gpu::div_up(n, 32768)));
}

}  // namespace

GroupNorm::GroupNorm(gpu::Context& ctx)
    : ctx_(ctx),
      partials_(ctx.program("nn/group_norm_partials")),
      stats_(ctx.program("nn/group_norm_stats")),
      apply_(ctx.program("nn/group_norm_apply")) {}

uint64_t GroupNorm::scratch_bytes(const GroupNormShape& s) {
  const uint64_t bg = uint64_t{s.batch} * s.groups;
  return gpu::align_up(bg * chunks_for(s) * 16, 256) + bg * 16;
}

void GroupNorm::record(gpu::CommandList& cmd, const GroupNormShape& s, const gpu::Buffer& x, const gpu::Buffer& weight,
                       const gpu::Buffer& bias, const gpu::Buffer* modulation, const gpu::Buffer& scratch,
                       const gpu::Buffer& y) {
  if (s.groups == 0 || s.channels % s.groups != 0)
    throw std::invalid_argument("group_norm: " + std::to_string(s.channels) + " channels in " + std::to_string(s.groups) +
                                " groups");
  if (s.modulate && !modulation) throw std::invalid_argument("group_norm: modulate without a modulation buffer");
  if (s.batch == 0 || s.spatial == 0) return;
  const uint64_t elements = uint64_t{s.batch} * s.channels * s.spatial, bytes = elements * 4;
  require_one_binding(ctx_, "group_norm", "tensor", elements);
  require_buffer("group_norm", "input", bytes, x);
  require_buffer("group_norm", "output", bytes, y);
  require_buffer("group_norm", "weight", uint64_t{s.channels} * 4, weight);
  require_buffer("group_norm", "bias", uint64_t{s.channels} * 4, bias);
  require_buffer("group_norm", "scratch", scratch_bytes(s), scratch);
  if (s.modulate) require_buffer("group_norm", "modulation", uint64_t{s.batch} * 2 * s.channels * 4, *modulation);

  shader::GroupNormParams pc{};
  pc.batch = s.batch;
  pc.channels = s.channels;
  pc.groups = s.groups;
  pc.spatial = static_cast<uint32_t>(s.spatial);
  pc.chunks = chunks_for(s);
  pc.eps = s.eps;
  pc.flags = (s.silu ? NN_GN_FLAG_SILU : 0u) | (s.modulate ? NN_GN_FLAG_MODULATE : 0u);
  const uint64_t bg = uint64_t{s.batch} * s.groups;
  const uint64_t partial_bytes = bg * pc.chunks * 16, stats_offset = gpu::align_up(partial_bytes, 256);
  const gpu::BufferBinding partials = scratch.binding(0, partial_bytes);
  const gpu::BufferBinding stats = scratch.binding(stats_offset, bg * 16);
  cmd.dispatch(partials_, gpu::Threads{bg * pc.chunks}, pc, {x.binding(0, bytes), partials});
  cmd.barrier(gpu::deps::kComputeToCompute);  // stats read the partials
  cmd.dispatch(stats_, gpu::Threads{bg}, pc, {partials, x.binding(0, bytes), stats});
  cmd.barrier(gpu::deps::kComputeToCompute);  // apply reads the statistics
  cmd.dispatch(apply_, gpu::Threads{elements}, pc,
               {x.binding(0, bytes), stats, weight.binding(0, uint64_t{s.channels} * 4),
                bias.binding(0, uint64_t{s.channels} * 4),
                s.modulate ? modulation->binding(0, uint64_t{s.batch} * 2 * s.channels * 4) : gpu::null_binding(),
                y.binding(0, bytes)});
}

}  // namespace icube::kernels::nn
