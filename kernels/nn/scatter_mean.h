// The GSM voxel lifter's scatter-mean: every effective pixel gives its image
// feature to the first voxel its ray enters; each voxel holds the mean of what
// it received (0 if nothing) — engine/nn/gsm/voxel_unet_reference.cpp's
// lift_pixel_features, features [N, C, H, W] -> [V, C].
// Deterministic, without atomics: build_voxel_pixel_lists groups the effective
// pixels by voxel on the host (a stable counting sort of first_voxel, which the
// CPU ray march produces: O(pixels + voxels)) into CSR lists, each in ascending
// pixel order q = n * H * W + row * W + column. GPU: ScatterMean::record
// (shaders/nn/scatter_mean.comp), one invocation per (voxel, channel) adds its
// list's features in list order in float32 and divides by the list length, so
// the result does not depend on scheduling, and windows / passes continue the
// same sum (bitwise equal to one dispatch). Windows when a tensor exceeds one
// binding: features by views (all channels) or by channels of one view; y,
// offsets and pixel ids by voxel ranges; an invocation sums at most
// NN_SM_PIXEL_WINDOW list entries per dispatch (lavapipe's 65,535 loop
// iterations), longer lists continue in further passes. Dispatches after the
// first follow a compute-to-compute barrier inside record() (they continue
// sums in y); none when everything fits one dispatch.
// CPU reference: nn::cpu::scatter_mean (scatter_mean_cpu.cpp, double sums in
// pixel order). Tests: tests/nn/test_scatter_mean.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

// The effective pixels grouped by the voxel they give their feature to.
struct VoxelPixelLists {
  uint32_t voxels = 0;
  uint64_t pixels = 0;              // N * H * W: the pixel ids' domain
  std::vector<uint32_t> offsets;    // [voxels + 1]: voxel v's list is pixel_ids[offsets[v], offsets[v + 1])
  std::vector<uint32_t> pixel_ids;  // q = n * H * W + row * W + column, ascending within a list
  uint32_t max_count = 0;           // the longest list
};

// first_voxel[q]: the voxel row pixel q gives its feature to, or -1; effective_mask[q] > 0: the pixel is
// effective. Rows must be < voxels (std::invalid_argument otherwise).
VoxelPixelLists build_voxel_pixel_lists(const std::vector<int32_t>& first_voxel, const std::vector<float>& effective_mask,
                                        uint32_t voxels);

struct ScatterMeanShape {
  uint32_t views = 1, channels = 1, height = 1, width = 1;  // the features [N, C, H, W]
};

class ScatterMean {
 public:
  explicit ScatterMean(gpu::Context& ctx);
  // y [lists.voxels, C] = the per-voxel mean of features [N, C, H, W]. `offsets` and `pixel_ids` hold
  // lists.offsets and lists.pixel_ids (uint32). The caller orders the inputs before and y after.
  void record(gpu::CommandList& cmd, const ScatterMeanShape& s, const gpu::Buffer& features, const VoxelPixelLists& lists,
              const gpu::Buffer& offsets, const gpu::Buffer& pixel_ids, const gpu::Buffer& y);
  // Tests: pretend one binding holds at most `bytes` (0 = the device's limits), and an invocation sums at
  // most `entries` list entries per dispatch (0 = NN_SM_PIXEL_WINDOW), to exercise the windows cheaply.
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }
  void set_pixel_window(uint32_t entries) { pixel_window_ = entries; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  uint64_t max_binding_bytes_ = 0;
  uint32_t pixel_window_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// features [N, C, H, W], first_voxel [N * H * W] (row or -1), effective_mask N * H * W values ([N, H, W];
// > 0 = effective) -> [voxels, C]: the mean of the effective pixels' features per first voxel, 0 where
// none arrived. Sums in double in pixel order (as lift_pixel_features).
CpuTensor scatter_mean(const CpuTensor& features, const std::vector<int32_t>& first_voxel, const CpuTensor& effective_mask,
                       int64_t voxels);

}  // namespace icube::nn::cpu
