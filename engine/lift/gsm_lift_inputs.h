// The GSM's inputs (nn::GsmInputs) assembled from an appearance-frames folder
// and the voxel world, for the learned lift (gsm_lift.h). The official
// counterpart is InfiniCube inference/scene_gaussian_generation.py
// (get_data_dict_from_folder, _create_gsm_input_masks, _prepare_gsm_batch):
//   grid frame  the model's voxels are 0.2 m with voxel ijk centred at 0.2 ijk + 0.1 (its voxel.pt: the
//               voxel world in the clip's first camera's FLU frame). Ours is our world frame translated so
//               that the world voxel `anchor` (the one holding the first key camera) is grid voxel 0:
//               the world's own 0.2 m lattice, unresampled, z up, near the origin (float32 positions);
//               the official frame differs by the first camera's yaw (and its small pitch and roll).
//   voxels      the static world's voxels within `radius` metres (horizontal) of a key camera (0: all;
//               the official passes the whole voxel world of the clip), sorted by ijk (x, then y, then z).
//   images      the key frames' RGB in [0, 1], resized to the model's size when it differs from the
//               frames' (bilinear, half-pixel centres as F.interpolate; the official video is already at
//               its 480 x 832), masks and instance ids by nearest.
//   intrinsics  (fx, fy, cx, cy, W, H) for the model's integer-pixel rays ((u - cx) / fx): a folder with
//               pixel-centre rays gets cx - 0.5; a resize by s scales f and moves c as
//               c' = s (c + 0.5) - 0.5 (pixel u' of the resized image samples the old u = (u' + 0.5) / s - 0.5).
//   poses       the frames' OpenCV camera-to-world, translated into the grid frame (rotation unchanged).
// Test: tests/lift/test_gsm_lift.cpp.
#pragma once

#include "kernels/nn/sparse_cpu.h"
#include "lift/lift_frames.h"
#include "render/camera.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace icube::lift {

struct GsmGridFrame {
  glm::ivec3 anchor{0};     // world ijk of grid voxel (0, 0, 0)
  glm::dvec3 offset{0.0};   // world position of the grid frame's origin (world = grid + offset)
  glm::dmat4 grid_to_world() const;
};

// The grid frame for `world` (0.2 m voxels, else scene::InputError naming `world_name`) anchored at the
// voxel holding `anchor_point`.
GsmGridFrame gsm_grid_frame(const world::VoxelGrid& world, const glm::dvec3& anchor_point, const std::string& world_name);

// The world's voxels within `radius` m of one of `cameras` in x and y (radius <= 0: every voxel), as grid
// ijk, sorted.
std::vector<nn::Ijk> gsm_crop_voxels(const world::VoxelGrid& world, const GsmGridFrame& g,
                                     const std::vector<glm::dvec3>& cameras, double radius);

// One key frame at the model's size.
struct GsmFrame {
  uint32_t width = 0, height = 0;
  std::vector<float> rgb;         // H * W * 3, [0, 1]
  std::vector<uint8_t> sky;       // H * W, nonzero = sky (the folder's sky mask)
  std::vector<uint16_t> instance; // H * W
};

// `im` (the folder's size `in_w` x `in_h`) at `out_w` x `out_h`.
GsmFrame gsm_frame(const FrameImages& im, uint32_t in_w, uint32_t in_h, uint32_t out_w, uint32_t out_h);

std::array<float, 6> gsm_intrinsics(const render::PinholeIntrinsics& K, render::PixelConvention pixels, uint32_t out_w,
                                    uint32_t out_h);
// Row-major camera-to-grid.
std::array<float, 16> gsm_pose(const glm::dmat4& c2w, const GsmGridFrame& g);

}  // namespace icube::lift
