// The GSM pixel branch's Gaussian decoding, host module; see gsm_pixel_gaussians.h.
#include "kernels/nn/gsm_pixel_gaussians.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

uint32_t gsm_pixel_camera_floats() { return NN_GSMPIX_CAMERA_FLOATS; }

std::vector<float> pack_gsm_pixel_cameras(const std::vector<std::array<float, 16>>& poses,
                                          const std::vector<std::array<float, 6>>& intrinsics) {
  if (poses.size() != intrinsics.size())
    throw std::invalid_argument("gsm_pixel_gaussians: " + std::to_string(poses.size()) + " poses for " +
                                std::to_string(intrinsics.size()) + " intrinsics");
  std::vector<float> out(poses.size() * NN_GSMPIX_CAMERA_FLOATS, 0.0f);
  for (size_t v = 0; v < poses.size(); ++v) {
    float* c = out.data() + v * NN_GSMPIX_CAMERA_FLOATS;
    for (size_t k = 0; k < 16; ++k) c[k] = poses[v][k];
    for (size_t k = 0; k < 4; ++k) c[16 + k] = intrinsics[v][k];
  }
  return out;
}

GsmPixelGaussians::GsmPixelGaussians(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/gsm_pixel_gaussians")) {}

void GsmPixelGaussians::record(gpu::CommandList& cmd, const GsmPixelGaussiansShape& s, const gpu::Buffer& params,
                               const gpu::Buffer& foreground, const gpu::Buffer& grid_foreground, const gpu::Buffer& cameras,
                               const gpu::Buffer& gaussians, const gpu::Buffer& mask) {
  if (s.gs_per_pixel == 0 || s.gs_dim < 10)
    throw std::invalid_argument("gsm_pixel_gaussians: needs gs_per_pixel >= 1 and gs_dim >= 10 (depth, scale 3, rotation 4, "
                                "opacity, colour), not " + std::to_string(s.gs_per_pixel) + " x " + std::to_string(s.gs_dim));
  const uint64_t raw = uint64_t{s.gs_per_pixel} * s.gs_dim;
  if (raw > NN_GSMPIX_MAX_PARAMS)
    throw std::invalid_argument("gsm_pixel_gaussians: " + std::to_string(raw) + " raw values per pixel exceed " +
                                std::to_string(NN_GSMPIX_MAX_PARAMS));
  const uint64_t V = s.views, P = s.pixels();
  if (V == 0 || P == 0) return;
  const uint64_t out_per_pixel = uint64_t{s.gs_per_pixel} * s.record_floats();
  require_buffer("gsm_pixel_gaussians", "params", V * raw * P * 4, params);
  require_buffer("gsm_pixel_gaussians", "foreground", V * P * 4, foreground);
  require_buffer("gsm_pixel_gaussians", "grid foreground", V * P * 4, grid_foreground);
  require_buffer("gsm_pixel_gaussians", "cameras", V * NN_GSMPIX_CAMERA_FLOATS * 4, cameras);
  require_buffer("gsm_pixel_gaussians", "gaussians", V * P * out_per_pixel * 4, gaussians);
  require_buffer("gsm_pixel_gaussians", "mask", V * P * 4, mask);
  require_one_binding(ctx_, "gsm_pixel_gaussians", "the cameras", V * NN_GSMPIX_CAMERA_FLOATS);
  // One view a dispatch: its raw values and outputs must each fit one binding.
  const uint64_t fit = window_elements(ctx_);
  if (raw * P > fit || out_per_pixel * P > fit)
    throw std::invalid_argument("gsm_pixel_gaussians: one view of " + std::to_string(P) + " pixels (" +
                                std::to_string(raw * P * 4) + " bytes of raw values, " + std::to_string(out_per_pixel * P * 4) +
                                " bytes of Gaussians) exceeds one storage binding; reduce the image size");

  shader::GsmPixelGaussiansParams pc{};
  pc.pixels = static_cast<uint32_t>(P);
  pc.width = s.width;
  pc.gs_per_pixel = s.gs_per_pixel;
  pc.gs_dim = s.gs_dim;
  pc.flags = (s.inverse_metric_depth ? NN_GSMPIX_FLAG_INVERSE_DEPTH : 0u) | (s.midground_only ? NN_GSMPIX_FLAG_MIDGROUND : 0u);
  pc.znear = s.znear;
  pc.depth_range = static_cast<float>(static_cast<double>(s.zfar) - static_cast<double>(s.znear));
  pc.max_scale = s.max_scale;
  const gpu::BufferBinding cam = cameras.binding(0, V * NN_GSMPIX_CAMERA_FLOATS * 4);
  for (uint64_t v = 0; v < V; ++v) {
    const ElementWindow rw = element_window(ctx_, params, v * raw * P, raw * P);
    const ElementWindow fw = element_window(ctx_, foreground, v * P, P);
    const ElementWindow gw = element_window(ctx_, grid_foreground, v * P, P);
    const ElementWindow ow = element_window(ctx_, gaussians, v * P * out_per_pixel, P * out_per_pixel);
    const ElementWindow mw = element_window(ctx_, mask, v * P, P);
    pc.camera = static_cast<uint32_t>(v * NN_GSMPIX_CAMERA_FLOATS);
    pc.params_offset = rw.offset;
    pc.fg_offset = fw.offset;
    pc.grid_offset = gw.offset;
    pc.out_offset = ow.offset;
    pc.mask_offset = mw.offset;
    cmd.dispatch(program_, gpu::Threads{P}, pc, {rw.binding, fw.binding, gw.binding, cam, ow.binding, mw.binding});
  }
}

}  // namespace icube::kernels::nn
