// The camera path of everything that renders along a trajectory (`icube
// generate`, `buffers`, `frames render`): the scene, the trajectory (a
// trajectory file, a route along the lanes, else the scene's ego track), the
// camera (given intrinsics, a preset, the trajectory file's, the scene's
// first, else waymo-front-480p) and the frame selection, resolved the same
// way for every such command so their frames line up by number. The CLI
// options that fill CameraPathArgs: tools/camera_path_options.h.
// Tests: through the commands (tests/render/test_cli_buffers.cpp, tests/lift/test_generate.cpp)
// and tests/pipeline/test_generate_package.cpp.
#pragma once

#include "render/buffers/trajectory.h"
#include "scene/input_error.h"
#include "scene/route.h"
#include "scene/scene.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace icube::pipeline {

struct CameraPathArgs {
  std::string scene, record, trajectory, camera, preset, frames;
  double route_m = 0.0;  // > 0: drive this far along the lanes
  scene::RouteOptions route;
  int64_t route_start_lane = 0;
  bool route_start_given = false;
};

struct CameraPath {
  std::optional<scene::Scene> scene;      // with tracks classified
  std::vector<render::Trajectory> passes;  // one, or P for a [P,N,4,4] trajectory file
  render::PinholeIntrinsics K;
  size_t total_frames() const;
};

CameraPath resolve_camera_path(const CameraPathArgs& a, scene::Diagnostics& diag);

}  // namespace icube::pipeline
