// 2-D resampling host module (F.interpolate by output size); see interpolate.h.
#include "kernels/nn/interpolate.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

static_assert(static_cast<uint32_t>(InterpolateMode::nearest) == NN_INTERP_NEAREST);
static_assert(static_cast<uint32_t>(InterpolateMode::bilinear) == NN_INTERP_BILINEAR);
static_assert(static_cast<uint32_t>(InterpolateMode::bicubic) == NN_INTERP_BICUBIC);

namespace {

// The shader's exact source positions take (2 out + 1) * in in 32-bit signed integers.
void require_axis(const char* axis, uint32_t in, uint32_t out) {
  if ((2 * uint64_t{out} + 1) * in > uint64_t{INT32_MAX})
    throw std::invalid_argument(std::string("interpolate: the ") + axis + " axis (" + std::to_string(in) + " -> " +
                                std::to_string(out) + ") is too long for 32-bit source positions");
}

}  // namespace

Interpolate::Interpolate(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/interpolate")) {}

void Interpolate::record(gpu::CommandList& cmd, const InterpolateShape& s, const gpu::Buffer& x, const gpu::Buffer& y) {
  const uint32_t mode = static_cast<uint32_t>(s.mode);
  if (mode > NN_INTERP_BICUBIC) throw std::invalid_argument("interpolate: unknown mode " + std::to_string(mode));
  if (s.mode == InterpolateMode::nearest && s.align_corners)
    throw std::invalid_argument("interpolate: align_corners applies to bilinear and bicubic only");
  const uint64_t planes = uint64_t{s.batch} * s.channels;
  if (planes == 0 || s.out_h == 0 || s.out_w == 0) return;
  if (s.in_h == 0 || s.in_w == 0) throw std::invalid_argument("interpolate: empty input map");
  require_axis("height", s.in_h, s.out_h);
  require_axis("width", s.in_w, s.out_w);
  const uint64_t in_plane = uint64_t{s.in_h} * s.in_w, out_plane = uint64_t{s.out_h} * s.out_w;
  require_buffer("interpolate", "input", planes * in_plane * 4, x);
  require_buffer("interpolate", "output", planes * out_plane * 4, y);

  // Windows of whole planes (one window when both tensors fit one binding), each bound from the
  // alignment at or below its first plane.
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  const uint64_t per_window = std::min(fit / std::max(in_plane, out_plane), planes);
  if (per_window == 0)
    throw std::invalid_argument("interpolate: one " + std::to_string(s.in_h) + " x " + std::to_string(s.in_w) + " -> " +
                                std::to_string(s.out_h) + " x " + std::to_string(s.out_w) + " plane (" +
                                std::to_string(std::max(in_plane, out_plane) * 4) + " bytes) exceeds one storage binding (" +
                                std::to_string(fit * 4) + " usable bytes)");
  shader::InterpolateParams pc{};
  pc.in_h = s.in_h;
  pc.in_w = s.in_w;
  pc.out_h = s.out_h;
  pc.out_w = s.out_w;
  pc.mode = mode;
  pc.align_corners = s.align_corners ? 1u : 0u;
  for (uint64_t p0 = 0; p0 < planes; p0 += per_window) {
    const uint64_t n = std::min(per_window, planes - p0);
    const ElementWindow xw = element_window(ctx_, x, p0 * in_plane, n * in_plane);
    const ElementWindow yw = element_window(ctx_, y, p0 * out_plane, n * out_plane);
    pc.planes = static_cast<uint32_t>(n);
    pc.x_offset = xw.offset;
    pc.y_offset = yw.offset;
    cmd.dispatch(program_, gpu::Threads{n * out_plane}, pc, {xw.binding, yw.binding});
  }
}

}  // namespace icube::kernels::nn
