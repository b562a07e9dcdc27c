// Plain-loop CPU reference of the voxel lifter's scatter-mean; see nn/scatter_mean.h.
#include "kernels/nn/scatter_mean.h"

#include <string>

namespace icube::nn::cpu {

using detail::D;
using detail::require;

CpuTensor scatter_mean(const CpuTensor& features, const std::vector<int32_t>& first_voxel, const CpuTensor& effective_mask,
                       int64_t voxels) {
  require(features.rank() == 4, "scatter_mean: features " + features.shape_text() + " are not [N, C, H, W]");
  const int64_t N = features.dim(0), C = features.dim(1), HW = features.dim(2) * features.dim(3);
  require(effective_mask.numel() == N * HW, "scatter_mean: effective mask " + effective_mask.shape_text() + " for features " +
                                                features.shape_text());
  require(static_cast<int64_t>(first_voxel.size()) == N * HW,
          "scatter_mean: " + std::to_string(first_voxel.size()) + " first-voxel rows for " + std::to_string(N * HW) + " pixels");
  require(voxels >= 0, "scatter_mean: negative voxel count");
  std::vector<double> sum(static_cast<size_t>(voxels * C), 0.0);
  std::vector<int64_t> count(static_cast<size_t>(voxels), 0);
  for (int64_t n = 0; n < N; ++n)
    for (int64_t p = 0; p < HW; ++p) {
      const int64_t q = n * HW + p;
      const int32_t row = first_voxel[static_cast<size_t>(q)];
      if (row < 0 || !(effective_mask.data[static_cast<size_t>(q)] > 0.0f)) continue;
      require(row < voxels, "scatter_mean: first-voxel row " + std::to_string(row) + " of " + std::to_string(voxels));
      ++count[static_cast<size_t>(row)];
      for (int64_t c = 0; c < C; ++c) sum[static_cast<size_t>(row * C + c)] += D(features.data[static_cast<size_t>((n * C + c) * HW + p)]);
    }
  CpuTensor y({voxels, C});
  for (int64_t v = 0; v < voxels; ++v) {
    const int64_t k = count[static_cast<size_t>(v)];
    if (k == 0) continue;
    for (int64_t c = 0; c < C; ++c)
      y.data[static_cast<size_t>(v * C + c)] = static_cast<float>(sum[static_cast<size_t>(v * C + c)] / static_cast<double>(k));
  }
  return y;
}

}  // namespace icube::nn::cpu
