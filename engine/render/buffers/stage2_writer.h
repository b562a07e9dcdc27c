// Writes a rendered GuidanceSequence in InfiniCube's Stage-2 layout
// (conventions §11; docs/guidance-buffers.md says which official reader
// reads each field) into one clip folder:
//
//   voxel_depth_100_480p_front.tar   <clip>.NNNNNN.voxel_depth_100.front.png  uint16 cm
//   instance_buffer_480p_front.tar   <clip>.NNNNNN.instance_buffer.front.png  uint16 ids
//   pose.tar                         <clip>.NNNNNN.pose.front.npy  4x4 float32 OpenCV c2w, voxel world
//   intrinsic.tar                    <clip>.intrinsic.front.npy  float64 [fx, fy, cx, cy, w, h]
//   dynamic_object_info.tar          <clip>.NNNNNN.dynamic_object_info.json
//   semantic_buffer_video_480p_front.mp4, coordinate_buffer_video_480p_front.mp4,
//   depth_vis_video_480p_front.mp4   H.264 (engine/video/mp4_writer.h: upstream's x264 settings, 10 fps)
//   world_to_voxel_world.npy         4x4 float64: our world frame -> InfiniCube's voxel world
//   semantic_buffer/NNNNNN.png       RGB8 (palette + PuRd instances)
//   coordinate_buffer/NNNNNN.png     RGB8; coordinate_points/NNNNNN.npy float32 [H, W, 3] (0 = invalid)
//   depth/NNNNNN.npy                 float32 [H, W] z-depth metres (0 = none)
//   depth_vis/NNNNNN.png             RGB8 colour-mapped depth (ours, for viewing)
//   normal_buffer/NNNNNN.png         optional
//   buffers_meta.json                camera, seed, pixel convention, coordinate range, instance colours,
//                                    source_frame_indices / source_time_indices of every written frame
// NNNNNN = the written frame's number 0 ... N-1, 6 digits, as upstream's
// writer numbers them (its readers look frames up by that number); the
// trajectory frame it came from is source_frame_indices[NNNNNN]. The "480p"
// in the names is upstream's fixed naming, kept for any image size.
// Voxel world (§1): world_to_voxel_world = inv(opencv_to_flu(voxel_world_pose0)),
// voxel_world_pose0 = the first camera of the clip (pass 0). Poses and
// object_to_world are written in that frame.
// Objects per frame (ObjectInfoMode::Moving, upstream's content): every
// dynamic vehicle track (ever moving, not the ego) in every frame, at its
// state of the frame's time index or the nearest valid one
// (scene::state_filled); gid = track id, object_lwh = [l, w, h],
// object_is_moving = that state moved > 0.05 m since the previous time index,
// object_type "car", object_id_int = instance id (10000, 10001, ...).
// ObjectInfoMode::Observed: every vehicle track but the ego, parked ones
// included, only in frames where it has a valid state. Frames without a time
// index get {}.
// Every file is written with scene::write_file_atomic (the mp4s by
// Mp4Writer, also through a temporary); PNG/NPY encoding runs on `threads` threads.
#pragma once

#include "render/buffers/guidance_sequence.h"
#include "scene/scene.h"
#include "video/mp4_writer.h"

#include <string>
#include <vector>

namespace icube::render {

enum class ObjectInfoMode {
  Moving,    // upstream: the ever-moving vehicles, filled into every frame
  Observed,  // every vehicle (parked too), only where observed
};
const char* object_info_mode_name(ObjectInfoMode m);

struct Stage2Options {
  std::string clip = "clip";
  bool videos = true;
  video::Mp4Options video;  // upstream's encoding by default
  ObjectInfoMode object_info = ObjectInfoMode::Moving;
  bool normals = false;
  unsigned threads = 0;      // 0 = hardware concurrency
};

struct Stage2Result {
  std::vector<std::string> notes;  // e.g. "videos disabled: no mp4 written"
  size_t files = 0;
  double write_s = 0.0, video_s = 0.0;
};

glm::dmat4 world_to_voxel_world(const glm::dmat4& first_camera_c2w_opencv);

// `dir` must exist.
Stage2Result write_stage2(const GuidanceSequence& seq, const scene::Scene* scene, const glm::dmat4& world_to_voxel,
                          const std::string& dir, const Stage2Options& opts);

// The dynamic_object_info JSON of one scene state (in the voxel world).
std::string dynamic_object_info_json(const scene::Scene* scene, int time_index, const glm::dmat4& world_to_voxel,
                                     ObjectInfoMode mode = ObjectInfoMode::Moving);

}  // namespace icube::render
