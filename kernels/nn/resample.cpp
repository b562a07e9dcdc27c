// The UNet's resampling on the GPU; see resample.h.
#include "kernels/nn/resample.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

Resample::Resample(gpu::Context& ctx) : ctx_(ctx), resample_(ctx.program("nn/resample")) {}

void Resample::run(gpu::CommandList& cmd, uint32_t op, const gpu::Buffer& x, uint32_t planes, uint32_t sx,
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
  require_buffer("nn resample", "input", in * 4, x);
  require_buffer("nn resample", "output", out * 4, y);
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

void Resample::avg_pool2(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy,
                            uint32_t sz, const gpu::Buffer& y) {
  run(cmd, NN_RS_AVGPOOL2, x, planes, sx, sy, sz, y);
}

void Resample::upsample2(gpu::CommandList& cmd, const gpu::Buffer& x, uint32_t planes, uint32_t sx, uint32_t sy,
                            uint32_t sz, const gpu::Buffer& y) {
  run(cmd, NN_RS_UPSAMPLE2, x, planes, sx, sy, sz, y);
}

}  // namespace icube::kernels::nn
