// The camera path of the commands that render along a trajectory (`icube
// buffers`, `icube frames render`): the scene, the trajectory (--trajectory
// file, a --route along the lanes, else the scene's ego track), the camera
// (--camera, --camera-preset, the trajectory file's, the scene's first, else
// waymo-front-480p) and the --frames selection, registered and resolved the
// same way for every such command so their frames line up by number.
#pragma once

#include "render/buffers/trajectory.h"
#include "scene/input_error.h"
#include "scene/route.h"
#include "scene/scene.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace icube::tools {

struct CameraPathArgs {
  std::string scene, record, trajectory, camera, preset, frames;
  double route_m = 0.0;  // > 0: drive this far along the lanes
  scene::RouteOptions route;
  int64_t route_start_lane = 0;
  bool route_start_given = false;
  // --scene, --record, --trajectory, --route*, --camera, --camera-preset, --frames. `this` must outlive cmd.
  void add_options(CLI::App* cmd);
};

struct CameraPath {
  std::optional<scene::Scene> scene;      // with tracks classified
  std::vector<render::Trajectory> passes;  // one, or P for a [P,N,4,4] trajectory file
  render::PinholeIntrinsics K;
  size_t total_frames() const;
};

CameraPath resolve_camera_path(const CameraPathArgs& a, scene::Diagnostics& diag);

}  // namespace icube::tools
