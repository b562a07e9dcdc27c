// The GSM's inputs for one forward, as a case folder holds them
// (../shared/data/models/gsm_small/inputs, its README "Files"): B batch
// elements of N views each, H x W pixels.
//   images.npy            [B, N, H, W, 3] float32 RGB in [0, 1]
//   masks.npy             [B, N, H, W, 4] uint8: ch0 foreground by segmentation (0 = sky), ch1 not dynamic,
//                         ch2 not hood/padding, ch3 grid foreground (recomputed by the model; ignored)
//   poses.npy             [B, N, 4, 4] float32 camera-to-grid, OpenCV camera axes; grid x forward, y left, z up
//   intrinsics.npy        [B, N, 6] float32 fx, fy, cx, cy, width, height
//   voxel_ijk.b<i>.npy    [V_i, 3] int32 voxel coordinates of batch element i (0.2 m voxels, origin 0.1 m)
//   depth_patch_keep.npy  [B, N, H/16, W/16] uint8: the pixel branch's random depth-patch draw (1 = kept)
// Every file is checked (dtype, shape, agreement with the images' B, N, H, W) and a
// bad one is a scene::InputError naming it.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "kernels/nn/sparse_cpu.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace icube::nn {

struct GsmInputs {
  int64_t batch = 0, views = 0, height = 0, width = 0;
  CpuTensor images;                         // [B, N, H, W, 3]
  std::vector<uint8_t> masks;               // [B, N, H, W, 4]
  std::vector<std::array<float, 16>> poses;  // [B * N], row-major 4x4 camera-to-grid
  std::vector<std::array<float, 6>> intrinsics;  // [B * N]: fx, fy, cx, cy, width, height
  std::vector<std::vector<Ijk>> voxel_ijk;  // [B][V_b]
  std::vector<uint8_t> depth_patch_keep;    // [B, N, H/16, W/16]

  int64_t patch_rows() const { return height / 16; }
  int64_t patch_cols() const { return width / 16; }
  uint8_t mask(int64_t b, int64_t n, int64_t row, int64_t col, int ch) const {
    return masks[static_cast<size_t>((((b * views + n) * height + row) * width + col) * 4 + ch)];
  }
};

// Reads a case folder (the files above); throws scene::InputError.
GsmInputs read_gsm_inputs(const std::string& dir);

// The images as the networks take them: [B * N, 3, H, W].
CpuTensor gsm_images_nchw(const GsmInputs& in);
// The effective pixels (not dynamic and not hood: mask ch1 && ch2) as [B, N, H, W] of 0 / 1
// (the reference's enc.effective_mask).
CpuTensor gsm_effective_mask(const GsmInputs& in);

}  // namespace icube::nn
