// The voxel heads' Gaussian decoding on the GPU; see gsm_voxel_gaussians.h.
#include "kernels/nn/gsm_voxel_gaussians.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

GsmVoxelGaussians::GsmVoxelGaussians(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/gsm_voxel_gaussians")) {}

void GsmVoxelGaussians::record(gpu::CommandList& cmd, const GsmVoxelGaussiansShape& s, const gpu::Buffer& raw,
                               const gpu::Buffer& ijk, const GsmGaussianBuffers& out) {
  if (s.gs_dim < 12) throw std::invalid_argument("gsm_voxel_gaussians: gs_dim " + std::to_string(s.gs_dim) + " < 12");
  if (s.per_voxel == 0) throw std::invalid_argument("gsm_voxel_gaussians: no Gaussians per voxel");
  if (!out.means || !out.scales || !out.rotations || !out.opacities || !out.colors)
    throw std::invalid_argument("gsm_voxel_gaussians: an output buffer is missing");
  last_dispatches_ = 0;
  const uint64_t n = uint64_t{s.rows} * s.per_voxel;
  if (n == 0) return;
  const uint64_t end = s.first_gaussian + n, color_dim = s.gs_dim - 11u;
  const uint64_t raw_count = n * s.gs_dim;
  require_buffer("gsm_voxel_gaussians", "raw", raw_count * 4, raw);
  require_buffer("gsm_voxel_gaussians", "ijk", uint64_t{s.rows} * 12, ijk);
  require_buffer("gsm_voxel_gaussians", "means", end * 12, *out.means);
  require_buffer("gsm_voxel_gaussians", "scales", end * 12, *out.scales);
  require_buffer("gsm_voxel_gaussians", "rotations", end * 16, *out.rotations);
  require_buffer("gsm_voxel_gaussians", "opacities", end * 4, *out.opacities);
  require_buffer("gsm_voxel_gaussians", "colors", end * color_dim * 4, *out.colors);
  // Windows: `subs` subs from s0 and `rows` voxels from r0 per dispatch, each binding within one window
  // (raw: (subs * gs_dim - 1) * all rows + rows values; the outputs: (rows - 1) * per_voxel + subs Gaussians).
  const uint64_t E = window_elements(ctx_);
  const uint64_t R = s.rows, dim_max = std::max<uint64_t>(4, color_dim);
  if ((uint64_t{s.gs_dim} - 1) * R + 1 > E || 3 > E || dim_max > E)
    throw std::invalid_argument("gsm_voxel_gaussians: " + std::to_string(R) + " voxels of " + std::to_string(s.gs_dim) +
                                " channel rows exceed one storage binding (" + std::to_string(E * 4) +
                                " bytes): give the head fewer voxels (fewer input voxels or key frames)");
  uint64_t subs = s.per_voxel;
  while (subs > 1 && (subs * s.gs_dim - 1) * R + 1 > E) --subs;
  const uint64_t rows_by_raw = E - (subs * s.gs_dim - 1) * R;
  const uint64_t rows_by_out = (E / dim_max - subs) / s.per_voxel + 1;
  const uint64_t window_rows = std::max<uint64_t>(1, std::min({R, rows_by_raw, rows_by_out, E / 3}));
  for (uint64_t s0 = 0; s0 < s.per_voxel; s0 += subs) {
    const uint64_t ns = std::min<uint64_t>(subs, s.per_voxel - s0);
    for (uint64_t r0 = 0; r0 < R; r0 += window_rows) {
      const uint64_t nr = std::min(window_rows, R - r0);
      const uint64_t g0 = s.first_gaussian + r0 * s.per_voxel + s0, gn = (nr - 1) * s.per_voxel + ns;
      const ElementWindow w_raw = element_window(ctx_, raw, s0 * s.gs_dim * R + r0, (ns * s.gs_dim - 1) * R + nr);
      const ElementWindow w_ijk = element_window(ctx_, ijk, 3 * r0, 3 * nr);
      const ElementWindow w_means = element_window(ctx_, *out.means, 3 * g0, 3 * gn);
      const ElementWindow w_scales = element_window(ctx_, *out.scales, 3 * g0, 3 * gn);
      const ElementWindow w_rot = element_window(ctx_, *out.rotations, 4 * g0, 4 * gn);
      const ElementWindow w_opa = element_window(ctx_, *out.opacities, g0, gn);
      const ElementWindow w_col = element_window(ctx_, *out.colors, color_dim * g0, color_dim * gn);
      shader::GsmVoxelGaussiansParams pc{};
      pc.rows = static_cast<uint32_t>(nr);
      pc.per_voxel = s.per_voxel;
      pc.gs_dim = s.gs_dim;
      pc.subs = static_cast<uint32_t>(ns);
      pc.row_stride = s.rows;
      pc.raw_offset = w_raw.offset;
      pc.ijk_offset = w_ijk.offset;
      pc.means_offset = w_means.offset;
      pc.scales_offset = w_scales.offset;
      pc.rotations_offset = w_rot.offset;
      pc.opacities_offset = w_opa.offset;
      pc.colors_offset = w_col.offset;
      pc.voxel_size_x = s.voxel_size[0];
      pc.voxel_size_y = s.voxel_size[1];
      pc.voxel_size_z = s.voxel_size[2];
      pc.scale_unit = s.scale_unit;
      pc.corner_x = s.origin[0] - s.voxel_size[0] / 2.0f;
      pc.corner_y = s.origin[1] - s.voxel_size[1] / 2.0f;
      pc.corner_z = s.origin[2] - s.voxel_size[2] / 2.0f;
      pc.max_scaling = s.max_scaling;
      cmd.dispatch(program_, gpu::Threads{nr * ns}, pc,
                   {w_raw.binding, w_ijk.binding, w_means.binding, w_scales.binding, w_rot.binding, w_opa.binding,
                    w_col.binding});
      ++last_dispatches_;
    }
  }
}

}  // namespace icube::kernels::nn
