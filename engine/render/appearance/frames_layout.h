// The appearance-frames folder that Stage 3 reads, written by `icube frames
// render` (procedural) and `icube frames import` (a video model's frames):
//
//   rgb/NNNNNN.png        RGB8 frame
//   sky_mask/NNNNNN.png   gray8, 255 = sky (no voxel hit, or segmented from the frame: "sky_mask")
//   instance/NNNNNN.png   gray16 instance id of the hit voxel (0 = none; cars >= 10000 dynamic)
//   frames_meta.json      {"format": "icube-frames", "version": 1, "source": "procedural" | "import",
//                          "width", "height", "count", "prompt", "appearance" (parsed prompt), "seed",
//                          "source_frame_indices", "source_time_indices", "camera" [fx, fy, cx, cy, w, h],
//                          "poses" (OpenCV camera-to-world 4x4 row-major per frame, our world frame),
//                          "pixels": "integer" | "centre" (the rays' pixel convention; absent: integer),
//                          "sky_mask": "buffers" | "segmentation" (where sky_mask/ came from; absent: buffers)}
//
// NNNNNN = 0 ... count - 1 as the guidance buffers number their frames (the
// same trajectory and --frames selection give the same numbers).
#pragma once

#include "render/appearance/prompt.h"
#include "render/camera.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace icube::render {

struct FramesMeta {
  std::string source = "procedural";
  uint32_t width = 0, height = 0;
  std::string prompt;
  AppearancePrompt parsed;
  uint64_t seed = 0;
  std::vector<int> source_frame_indices, source_time_indices;
  PinholeIntrinsics K;
  std::vector<glm::dmat4> poses;
  PixelConvention pixels = PixelConvention::Integer;
  std::string sky_mask = "buffers";  // "buffers" | "segmentation"
  std::vector<std::string> notes;
};

std::string frame_file_name(size_t index);  // "000012.png"
std::string frames_meta_json(const FramesMeta& m);
// Reads DIR/frames_meta.json and checks that every frame's rgb/, sky_mask/ and instance/ PNG
// exists. Throws scene::InputError "FILE: /json/pointer: what" for a malformed or inconsistent
// file (poses not one per frame, non-finite or non-rigid poses, a bad camera, a missing PNG).
FramesMeta read_frames_meta(const std::string& dir);

}  // namespace icube::render
