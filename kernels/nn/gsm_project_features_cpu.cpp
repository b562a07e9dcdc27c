// Plain-loop CPU reference of the projected-feature sampling; see nn/gsm_project_features.h.
#include "kernels/nn/gsm_project_features.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

namespace {

// F.grid_sample(bilinear, zeros, align_corners=False) of view n's masked channel c at pixel position (x, y).
double sample_view(const CpuTensor& features, const CpuTensor& mask, int64_t n, int64_t c, double x, double y) {
  const int64_t C = features.dim(1), h = features.dim(2), w = features.dim(3);
  if (!std::isfinite(x) || !std::isfinite(y)) return 0.0;
  const double x0 = std::floor(x), y0 = std::floor(y);
  const double fx = x - x0, fy = y - y0;
  double acc = 0.0;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const double col = x0 + dx, row = y0 + dy;
      if (col < 0 || row < 0 || col >= static_cast<double>(w) || row >= static_cast<double>(h)) continue;
      const int64_t pix = static_cast<int64_t>(row) * w + static_cast<int64_t>(col);
      if (!(mask.data[static_cast<size_t>(n * h * w + pix)] > 0.0f)) continue;
      const double weight = (dx ? fx : 1.0 - fx) * (dy ? fy : 1.0 - fy);
      acc += weight * D(features.data[static_cast<size_t>((n * C + c) * h * w + pix)]);
    }
  return acc;
}

}  // namespace

CpuTensor gsm_project_features(const CpuTensor& features, const CpuTensor& mask, const std::vector<int32_t>& ijk,
                               const std::vector<int32_t>& parent, const std::vector<uint32_t>& seen,
                               const std::vector<double>& proj, const std::array<double, 3>& voxel_size,
                               const std::array<double, 3>& origin, bool max_from_zero) {
  require(features.rank() == 4, "gsm_project_features: features " + features.shape_text() + " are not [N, C, h, w]");
  const int64_t N = features.dim(0), C = features.dim(1), h = features.dim(2), w = features.dim(3);
  require(mask.shape == std::vector<int64_t>{N, h, w}, "gsm_project_features: mask " + mask.shape_text() + " for features " + features.shape_text());
  require(ijk.size() == parent.size() * 3, "gsm_project_features: ijk and parent disagree in rows");
  require(N > 0 && seen.size() % static_cast<size_t>(N) == 0, "gsm_project_features: the seen table is not [P, N]");
  require(proj.size() == static_cast<size_t>(N) * 12, "gsm_project_features: needs a 3x4 projection per view");
  const int64_t R = static_cast<int64_t>(parent.size()), P = static_cast<int64_t>(seen.size()) / N;
  CpuTensor y({R, C});
  for (int64_t r = 0; r < R; ++r) {
    const int32_t par = parent[static_cast<size_t>(r)];
    require(par >= 0 && par < P, "gsm_project_features: parent row " + std::to_string(par) + " of " + std::to_string(P));
    double xyz[3];
    for (size_t a = 0; a < 3; ++a) xyz[a] = ijk[static_cast<size_t>(r) * 3 + a] * voxel_size[a] + origin[a];
    for (int64_t c = 0; c < C; ++c) {
      double best = max_from_zero ? 0.0 : -std::numeric_limits<double>::infinity();
      for (int64_t n = 0; n < N; ++n) {
        double v = 0.0;
        if (seen[static_cast<size_t>(par * N + n)] != 0) {
          double pt[3];
          for (size_t s = 0; s < 3; ++s) {
            const double* m = proj.data() + n * 12 + static_cast<int64_t>(s) * 4;
            pt[s] = m[0] * xyz[0] + m[1] * xyz[1] + m[2] * xyz[2] + m[3];
          }
          v = sample_view(features, mask, n, c, pt[0] / pt[2] * static_cast<double>(w) - 0.5,
                          pt[1] / pt[2] * static_cast<double>(h) - 0.5);
        }
        best = std::max(best, v);
      }
      y.data[static_cast<size_t>(r * C + c)] = static_cast<float>(best);
    }
  }
  return y;
}

}  // namespace icube::nn::cpu
