// Camera trajectories for the guidance buffers: where each frame's camera is
// and which scene state (dynamic cars) it sees.
//
// Every pose is an OpenCV camera-to-world 4x4 (x right, y down, z forward) in
// OUR world frame: the scene's world frame, in which the VoxelGrid is
// axis-aligned (not InfiniCube's voxel world; the writer converts).
// Sources:
//  - the scene's ego track with a scene camera: pose_i =
//    flu_to_opencv(ego_to_world_i · camera_to_ego) (frames.h), frame i = time
//    index i; invalid ego poses are skipped.
//  - a route sampled along the map's lanes (scene/route.h sample_route):
//    the route's ego poses with the camera, frame i seeing the original
//    scene's state min(i, T - 1), like a recorded trajectory (the route
//    drives at its own pace, so dynamic cars move on their own clock);
//  - a .npy: float32/float64 [N,4,4] (one pass) or [P,N,4,4] (P passes, as
//    InfiniCube's multi_pass_camera_poses.npy), C order, row-major matrices.
//  - a JSON file:
//      {"format": "icube-trajectory", "version": 1,
//       "poses": [[[r00,r01,r02,r03],[r10,...],[r20,...],[0,0,0,1]], ...],
//       "camera": {"fx":.., "fy":.., "cx":.., "cy":.., "width":.., "height":..},  (optional)
//       "time_indices": [0, 1, ...]}                                               (optional)
//    poses row-major OpenCV c2w in our world frame.
// Recorded poses see scene state min(i, T - 1) (InfiniCube: missing object
// frames repeat the last one) unless time_indices says otherwise; without a
// scene, no dynamic cars.
// Bad files throw scene::InputError naming the file.
#pragma once

#include "render/camera.h"
#include "scene/route.h"
#include "scene/scene.h"

#include <glm/glm.hpp>

#include <optional>
#include <string>
#include <vector>

namespace icube::render {

struct Trajectory {
  std::vector<glm::dmat4> c2w;   // OpenCV camera-to-world, our world frame
  std::vector<int> frame_index;  // the frame's number in file names (NNNNNN)
  std::vector<int> time_index;   // scene state for dynamic cars, -1 = none
  size_t size() const { return c2w.size(); }
};

struct TrajectoryFile {
  std::vector<Trajectory> passes;          // one for [N,4,4] and JSON
  std::optional<PinholeIntrinsics> camera; // JSON "camera"
};

Trajectory ego_trajectory(const scene::Scene& s, const scene::Camera& cam);
// Throws like scene::sample_route (no usable lanes, unknown start lane, bad options).
Trajectory route_trajectory(const scene::Scene& s, const scene::Camera& cam, const scene::RouteOptions& options,
                            scene::RouteReport* report = nullptr);
// `scene_states`: number of scene timestamps (0 = no scene).
TrajectoryFile load_trajectory(const std::string& path, size_t scene_states);

// "A:B" (B exclusive), "A:" or ":B", "A" (one frame), and "A:B:S" / "::S" (every S-th
// position, like a Python slice); over positions in the trajectory.
// The icube-trajectory JSON (above) of one pass: poses, the camera when given, the time indices
// when given (one per pose). Written by `icube generate` (the package's trajectory.json) and the viewer.
std::string trajectory_json(const std::vector<glm::dmat4>& c2w, const std::optional<PinholeIntrinsics>& camera,
                            const std::vector<int>* time_indices = nullptr);

struct FrameRange {
  long begin = 0;
  long end = -1;  // -1 = to the end
  long step = 1;  // >= 1
};
FrameRange parse_frame_range(const std::string& text);  // throws std::invalid_argument
// Keeps positions begin, begin + step, ... < end (clamped); throws std::invalid_argument when nothing is left.
Trajectory select_frames(const Trajectory& t, const FrameRange& r);

// "fx,fy,cx,cy,w,h"; throws std::invalid_argument.
PinholeIntrinsics parse_camera(const std::string& text);
// "waymo-front-480p": Waymo FRONT rescaled to 832x480 (frames.h). Throws std::invalid_argument for others.
scene::Camera camera_preset(const std::string& name);
PinholeIntrinsics intrinsics_of(const scene::Camera& c);

}  // namespace icube::render
