// The GSM's pixel rays against its input voxel grid (gsm_small README steps 1,
// 5, 6 and "Ray casting"), as the official code gets them from fVDB:
//   ray         pixel (u, v) at integer coordinates: ((u - cx) / fx, (v - cy) / fy, 1, 1) through the
//               camera-to-grid pose, minus the camera centre, normalised — in float32, operation by operation
//               as create_rays_from_intrinsic_torch_batch does
//   march       in double: voxel ijk is the box [ijk, ijk + 1) in (x - origin) / voxel size + 0.5; the ray is
//               clipped to the bounding box of all voxels and to t >= 0 and walked voxel by voxel (3-D DDA);
//               t is the distance along the unit ray
//   first hit   the first voxel of the grid the walk enters, the one the ray starts in included
//               (voxels_along_rays, max_voxels 1, eps 0) -> vox.lifter.pixel_first_voxel.b<i>
//   segments    runs of consecutively entered voxels of the grid, [t entering the first, t leaving the last];
//               runs shorter than eps are skipped (segments_along_rays): eps 1 mm -> the grid-foreground
//               mask pre.grid_fg_mask; eps 0.1 m -> the start distance times the cosine between the ray and
//               the optical axis (the pose's third column, normalised) -> pix.voxel_depth (0 without one)
// Test: tests/nn/test_gsm_voxel_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/sparse_cpu.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_trace.h"

#include <array>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

namespace icube::nn {

// The input grids' convention (GsmInputs: 0.2 m voxels, origin 0.1 m = the centre of voxel 0).
constexpr double kGsmVoxelSize = 0.2;
constexpr double kGsmVoxelOrigin = 0.1;
// The official thresholds (voxel_util.get_mask_as_alpha_gt / get_depth_from_voxel), metres.
constexpr double kGsmGridMaskMinSegment = 1e-3;
constexpr double kGsmDepthMinSegment = 0.1;

// Batch element b's input voxels as a grid (rows in the file's order).
SparseGrid gsm_input_grid(const GsmInputs& in, int64_t b);

// The float32 unit direction of pixel (u, v), grid frame.
std::array<float, 3> gsm_pixel_ray_direction(const std::array<float, 16>& pose, const std::array<float, 6>& intrinsics,
                                             int64_t u, int64_t v);

// One ray's walk through a grid.
struct VoxelRayWalk {
  int32_t first_voxel = -1;                     // grid row of the first voxel entered, -1 if none
  std::vector<std::array<double, 2>> segments;  // runs of consecutively entered voxels, [t0, t1]
  // Where the first run at least min_length long starts, or -1 if none.
  double first_segment_start(double min_length) const;
};

// A grid prepared for ray marching.
class VoxelRayGrid {
 public:
  explicit VoxelRayGrid(const SparseGrid& grid);
  // origin and unit direction in world (grid-frame) coordinates.
  VoxelRayWalk march(const std::array<double, 3>& origin, const std::array<double, 3>& direction) const;
  // The grid row of voxel (i, j, k), -1 if it is not in the grid.
  int32_t row_of(int64_t i, int64_t j, int64_t k) const;

 private:
  std::unordered_map<uint64_t, int32_t> rows_;
  std::array<double, 3> voxel_size_{}, origin_{};
  std::array<int64_t, 3> lo_{}, hi_{};  // bounding box of the voxels, [lo, hi] inclusive
};

// Every pixel of every view of one batch element, [N, H, W] row-major.
struct GsmPixelRays {
  int64_t views = 0, height = 0, width = 0;
  std::vector<int32_t> first_voxel;      // row of the first voxel entered, -1 = none
  std::vector<uint8_t> grid_foreground;  // a run of at least 1 mm
  std::vector<float> voxel_depth;        // metres along the optical axis, 0 = none
};

// One pixel's results.
struct GsmPixelRay {
  int32_t first_voxel = -1;
  uint8_t grid_foreground = 0;
  float voxel_depth = 0.0f;
};
// The optical axis of a camera-to-grid pose: its third column, normalised in float32.
std::array<float, 3> gsm_optical_axis(const std::array<float, 16>& pose);
// Pixel (u, v)'s ray marched through `grid` in double (the reference for every pixel).
GsmPixelRay march_gsm_pixel(const VoxelRayGrid& grid, const std::array<float, 16>& pose,
                            const std::array<float, 6>& intrinsics, int64_t u, int64_t v);
// Throws unless every view's intrinsics are for the images' width x height.
void check_gsm_ray_intrinsics(const GsmInputs& in, int64_t batch_element);
// fn(i) for i in [0, n) on up to hardware_concurrency threads, `grain` indices a task.
void gsm_parallel_for(int64_t n, int64_t grain, const std::function<void(int64_t)>& fn);

// Image rows in parallel on up to hardware_concurrency threads (the result does not depend on the count).
// The GPU route: engine/nn/gsm/gsm_rays_gpu.h (the same results).
GsmPixelRays cast_gsm_pixel_rays(const GsmInputs& in, int64_t batch_element);

// Records vox.lifter.pixel_first_voxel.b<i> [N, H, W] per element and the batch-wide pre.grid_fg_mask and
// pix.voxel_depth [B, N, H, W] (all_elements[b] = element b's rays).
void trace_gsm_pixel_rays(const std::vector<GsmPixelRays>& all_elements, GsmTrace* trace);

}  // namespace icube::nn
