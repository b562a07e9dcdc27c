// The voxel heads' Gaussian decoding on the GPU; see gsm_voxel_gaussians.h.
#include "kernels/nn/gsm_voxel_gaussians.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_gsm_params.h"

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
  require_one_binding(ctx_, "gsm_voxel_gaussians", "raw values", raw_count);
  require_one_binding(ctx_, "gsm_voxel_gaussians", "rotations", end * 4);
  require_one_binding(ctx_, "gsm_voxel_gaussians", "colors", end * color_dim);
  shader::GsmVoxelGaussiansParams pc{};
  pc.rows = s.rows;
  pc.per_voxel = s.per_voxel;
  pc.gs_dim = s.gs_dim;
  pc.first_gaussian = s.first_gaussian;
  pc.voxel_size_x = s.voxel_size[0];
  pc.voxel_size_y = s.voxel_size[1];
  pc.voxel_size_z = s.voxel_size[2];
  pc.scale_unit = s.scale_unit;
  pc.corner_x = s.origin[0] - s.voxel_size[0] / 2.0f;
  pc.corner_y = s.origin[1] - s.voxel_size[1] / 2.0f;
  pc.corner_z = s.origin[2] - s.voxel_size[2] / 2.0f;
  pc.max_scaling = s.max_scaling;
  cmd.dispatch(program_, gpu::Threads{n}, pc,
               {raw.binding(0, raw_count * 4), ijk.binding(0, uint64_t{s.rows} * 12), out.means->binding(0, end * 12),
                out.scales->binding(0, end * 12), out.rotations->binding(0, end * 16), out.opacities->binding(0, end * 4),
                out.colors->binding(0, end * color_dim * 4)});
}

}  // namespace icube::kernels::nn
