// GroupNorm host module; see group_norm.h.
#include "kernels/nn/group_norm.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
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
  const uint64_t y_element = s.f16_output ? 2 : 4;
  require_buffer("group_norm", "input", bytes, x);
  require_buffer("group_norm", "output", elements * y_element, y);
  if (s.f16_output) require_f16_storage(ctx_, "group_norm", "an fp16 output");
  gpu::Program& apply = s.f16_output ? ctx_.program("nn/group_norm_apply_f16out") : apply_;
  require_buffer("group_norm", "weight", uint64_t{s.channels} * 4, weight);
  require_buffer("group_norm", "bias", uint64_t{s.channels} * 4, bias);
  require_buffer("group_norm", "scratch", scratch_bytes(s), scratch);
  if (s.modulate) require_buffer("group_norm", "modulation", uint64_t{s.batch} * 2 * s.channels * 4, *modulation);

  shader::GroupNormParams pc{};
  pc.spatial = static_cast<uint32_t>(s.spatial);
  pc.eps = s.eps;
  pc.flags = (s.silu ? NN_GN_FLAG_SILU : 0u) | (s.modulate ? NN_GN_FLAG_MODULATE : 0u);
  pc.channels_total = s.channels;
  const gpu::BufferBinding wb = weight.binding(0, uint64_t{s.channels} * 4), bb = bias.binding(0, uint64_t{s.channels} * 4);
  const gpu::BufferBinding mb =
      s.modulate ? modulation->binding(0, uint64_t{s.batch} * 2 * s.channels * 4) : gpu::null_binding();
  const uint32_t cpg = s.channels / s.groups;
  const uint64_t group_elements = uint64_t{cpg} * s.spatial;
  // One window = `batch` batch elements x `groups` whole groups from group g0, all in one binding each.
  auto run = [&](uint32_t batch, uint32_t b0, uint32_t groups, uint32_t g0) {
    const GroupNormShape ws{batch, groups * cpg, groups, s.spatial, s.eps, s.silu, s.modulate, s.f16_output};
    pc.batch = batch;
    pc.channels = groups * cpg;
    pc.groups = groups;
    pc.chunks = chunks_for(ws);
    pc.channel_offset = g0 * cpg;
    pc.batch_offset = b0;
    const uint64_t first = (uint64_t{b0} * s.channels + uint64_t{g0} * cpg) * s.spatial;
    const uint64_t count = uint64_t{batch} * pc.channels * s.spatial;
    const ElementWindow xw = element_window(ctx_, x, first, count), yw = element_window(ctx_, y, first, count, y_element);
    pc.x_offset = xw.offset;
    pc.y_offset = yw.offset;
    const uint64_t bg = uint64_t{batch} * groups;
    const uint64_t partial_bytes = bg * pc.chunks * 16, stats_offset = gpu::align_up(partial_bytes, 256);
    const gpu::BufferBinding partials = scratch.binding(0, partial_bytes);
    const gpu::BufferBinding stats = scratch.binding(stats_offset, bg * 16);
    pc.span_begin = 0;
    pc.span_end = static_cast<uint32_t>(group_elements);
    cmd.dispatch(partials_, gpu::Threads{bg * pc.chunks}, pc, {xw.binding, partials});
    cmd.barrier(gpu::deps::kComputeToCompute);  // stats read the partials
    cmd.dispatch(stats_, gpu::Threads{bg}, pc, {partials, stats});
    cmd.barrier(gpu::deps::kComputeToCompute);  // apply reads the statistics
    pc.span_end = static_cast<uint32_t>(count);
    cmd.dispatch(apply, gpu::Threads{count}, pc, {xw.binding, stats, wb, bb, mb, yw.binding});
  };
  // One group larger than a binding: its elements in spans of `fit`, the partials continued span by
  // span (a barrier between, as each reads and writes the same triples), then the statistics, then
  // the spans applied.
  auto run_split = [&](uint32_t b, uint32_t g, uint64_t fit) {
    const GroupNormShape ws{1, cpg, 1, s.spatial, s.eps, s.silu, s.modulate, s.f16_output};
    pc.batch = 1;
    pc.channels = cpg;
    pc.groups = 1;
    pc.chunks = chunks_for(ws);
    pc.channel_offset = g * cpg;
    pc.batch_offset = b;
    const uint64_t group_first = (uint64_t{b} * s.channels + uint64_t{g} * cpg) * s.spatial;
    const uint64_t partial_bytes = uint64_t{pc.chunks} * 16, stats_offset = gpu::align_up(partial_bytes, 256);
    const gpu::BufferBinding partials = scratch.binding(0, partial_bytes);
    const gpu::BufferBinding stats = scratch.binding(stats_offset, 16);
    for (uint64_t s0 = 0; s0 < group_elements; s0 += fit) {
      const uint64_t s1 = std::min(group_elements, s0 + fit);
      const ElementWindow xw = element_window(ctx_, x, group_first + s0, s1 - s0);
      pc.x_offset = xw.offset;
      pc.span_begin = static_cast<uint32_t>(s0);
      pc.span_end = static_cast<uint32_t>(s1);
      pc.flags = (pc.flags & ~NN_GN_FLAG_CONTINUE) | (s0 > 0 ? NN_GN_FLAG_CONTINUE : 0u);
      if (s0 > 0) cmd.barrier(gpu::deps::kComputeToCompute);  // continue the previous span's partials
      cmd.dispatch(partials_, gpu::Threads{pc.chunks}, pc, {xw.binding, partials});
    }
    pc.flags &= ~NN_GN_FLAG_CONTINUE;
    cmd.barrier(gpu::deps::kComputeToCompute);  // stats read the partials
    cmd.dispatch(stats_, gpu::Threads{1}, pc, {partials, stats});
    cmd.barrier(gpu::deps::kComputeToCompute);  // apply reads the statistics
    for (uint64_t s0 = 0; s0 < group_elements; s0 += fit) {
      const uint64_t s1 = std::min(group_elements, s0 + fit);
      const ElementWindow xw = element_window(ctx_, x, group_first + s0, s1 - s0);
      const ElementWindow yw = element_window(ctx_, y, group_first + s0, s1 - s0, y_element);
      pc.x_offset = xw.offset;
      pc.y_offset = yw.offset;
      pc.span_begin = static_cast<uint32_t>(s0);
      pc.span_end = static_cast<uint32_t>(s1);
      cmd.dispatch(apply, gpu::Threads{s1 - s0}, pc, {xw.binding, stats, wb, bb, mb, yw.binding});
    }
  };
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  if (elements <= fit) {
    run(s.batch, 0, s.groups, 0);
    return;
  }
  // Windows: one batch element and as many whole groups as fit (or one group in spans); the scratch
  // is reused, so each window's partials wait for the previous window's apply to have read its statistics.
  const uint64_t groups_per_window = std::min<uint64_t>(fit / group_elements, s.groups);
  if (fit == 0) throw std::invalid_argument("group_norm: a storage binding holds no element");
  bool first_window = true;
  for (uint32_t b = 0; b < s.batch; ++b)
    for (uint64_t g0 = 0; g0 < s.groups; g0 += std::max<uint64_t>(groups_per_window, 1)) {
      if (!first_window) cmd.barrier(gpu::deps::kComputeToCompute);  // scratch reuse
      first_window = false;
      if (groups_per_window == 0)
        run_split(b, static_cast<uint32_t>(g0), fit);
      else
        run(1, b, static_cast<uint32_t>(std::min<uint64_t>(groups_per_window, s.groups - g0)), static_cast<uint32_t>(g0));
    }
}

}  // namespace icube::kernels::nn
