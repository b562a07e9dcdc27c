// Writes a rendered GuidanceSequence in InfiniCube's Stage-2 layout
// (conventions §11) into one clip folder:
//
//   voxel_depth_100_480p_front.tar   <clip>.NNNNNN.voxel_depth_100.front.png  uint16 cm
//   instance_buffer_480p_front.tar   <clip>.NNNNNN.instance_buffer.front.png  uint16 ids
//   pose.tar                         <clip>.NNNNNN.pose.front.npy  4x4 float64 OpenCV c2w, voxel world
//   intrinsic.tar                    <clip>.intrinsic.front.npy  float64 [fx, fy, cx, cy, w, h]
//   dynamic_object_info.tar          <clip>.NNNNNN.dynamic_object_info.json
//   world_to_voxel_world.npy         4x4 float64: our world frame -> InfiniCube's voxel world
//   semantic_buffer/NNNNNN.png       RGB8 (palette + PuRd instances)
//   coordinate_buffer/NNNNNN.png     RGB8; coordinate_points/NNNNNN.npy float32 [H, W, 3] (0 = invalid)
//   depth/NNNNNN.npy                 float32 [H, W] z-depth metres (0 = none)
//   depth_vis/NNNNNN.png             RGB8 colour-mapped depth (ours, for viewing)
//   normal_buffer/NNNNNN.png         optional
//   semantic_buffer_video_480p_front.mp4, coordinate_buffer_video_480p_front.mp4,
//   depth_vis_video_480p_front.mp4   when ffmpeg is on PATH
//   buffers_meta.json                camera, seed, pixel convention, coordinate range, instance colours
// NNNNNN = Trajectory::frame_index, 6 digits. The "480p" in the names is
// upstream's fixed naming, kept for any image size.
// Voxel world (§1): world_to_voxel_world = inv(opencv_to_flu(voxel_world_pose0)),
// voxel_world_pose0 = the first camera of the clip (pass 0). Poses and
// object_to_world are written in that frame. Objects per frame: every vehicle
// track but the ego valid at the frame's time index, gid = track id,
// object_lwh = [l, w, h], object_is_moving = centre moved > 0.05 m since the
// previous state, object_type "car", object_id_int = instance id; frames
// without a time index get {}.
// Every file is written with scene::write_file_atomic; PNG/NPY encoding runs
// on `threads` threads.
#pragma once

#include "render/buffers/guidance_sequence.h"
#include "scene/scene.h"

#include <string>
#include <vector>

namespace icube::render {

struct Stage2Options {
  std::string clip = "clip";
  bool videos = true;        // only when ffmpeg is found
  bool normals = false;
  unsigned threads = 0;      // 0 = hardware concurrency
};

struct Stage2Result {
  std::vector<std::string> notes;  // e.g. "ffmpeg not found on PATH: no mp4 written"
  size_t files = 0;
  double write_s = 0.0, video_s = 0.0;
};

glm::dmat4 world_to_voxel_world(const glm::dmat4& first_camera_c2w_opencv);

// `dir` must exist.
Stage2Result write_stage2(const GuidanceSequence& seq, const scene::Scene* scene, const glm::dmat4& world_to_voxel,
                          const std::string& dir, const Stage2Options& opts);

// The dynamic_object_info JSON of one scene state (in the voxel world).
std::string dynamic_object_info_json(const scene::Scene* scene, int time_index, const glm::dmat4& world_to_voxel);

}  // namespace icube::render
