// Plain-loop CPU reference of the voxel heads' Gaussian decoding; see nn/gsm_voxel_gaussians.h.
#include "kernels/nn/gsm_voxel_gaussians.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

namespace {

double sigmoid(double v) { return 1.0 / (1.0 + std::exp(-v)); }

}  // namespace

GsmGaussians gsm_voxel_gaussians(const CpuTensor& raw, const std::vector<int32_t>& ijk, int64_t per_voxel, int64_t gs_dim,
                                 const std::array<float, 3>& voxel_size, const std::array<float, 3>& origin,
                                 float scale_unit, float max_scaling) {
  require(gs_dim >= 12 && per_voxel >= 1, "gsm_voxel_gaussians: gs_dim " + std::to_string(gs_dim) + ", per_voxel " + std::to_string(per_voxel));
  require(raw.rank() == 2 && raw.dim(1) == per_voxel * gs_dim, "gsm_voxel_gaussians: raw " + raw.shape_text() + " is not [rows, " +
                                                                    std::to_string(per_voxel * gs_dim) + "]");
  const int64_t rows = raw.dim(0), n = rows * per_voxel, color_dim = gs_dim - 11;
  require(static_cast<int64_t>(ijk.size()) == rows * 3, "gsm_voxel_gaussians: ijk for " + std::to_string(ijk.size() / 3) + " voxels");
  GsmGaussians g{CpuTensor({n, 3}), CpuTensor({n, 3}), CpuTensor({n, 4}), CpuTensor({n, 1}), CpuTensor({n, color_dim})};
  for (int64_t r = 0; r < rows; ++r)
    for (int64_t s = 0; s < per_voxel; ++s) {
      const float* v = raw.data.data() + r * raw.dim(1) + s * gs_dim;
      const size_t i = static_cast<size_t>(r * per_voxel + s);
      for (size_t a = 0; a < 3; ++a) {
        const double min_corner = (ijk[static_cast<size_t>(r) * 3 + a] - 0.5) * D(voxel_size[a]) + D(origin[a]);
        g.means.data[i * 3 + a] = static_cast<float>(min_corner + sigmoid(D(v[a])) * D(voxel_size[a]));
        double scale = std::exp(D(v[3 + a])) * D(scale_unit);
        if (max_scaling > 0.0f) scale = std::min(scale, D(max_scaling));
        g.scales.data[i * 3 + a] = static_cast<float>(scale);
      }
      double norm = 0.0;
      for (size_t a = 0; a < 4; ++a) norm += D(v[6 + a]) * D(v[6 + a]);
      norm = std::max(std::sqrt(norm), 1e-12);
      for (size_t a = 0; a < 4; ++a) g.rotations.data[i * 4 + a] = static_cast<float>(D(v[6 + a]) / norm);
      g.opacities.data[i] = static_cast<float>(sigmoid(D(v[10])));
      for (int64_t a = 0; a < color_dim; ++a) g.colors.data[i * static_cast<size_t>(color_dim) + static_cast<size_t>(a)] = v[11 + a];
    }
  return g;
}

}  // namespace icube::nn::cpu
