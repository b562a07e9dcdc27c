// The options every command that renders along a trajectory registers the
// same way (`icube generate`, `buffers`, `frames render`, `frames sheet`):
// --scene, --record, --trajectory, --route*, --camera, --camera-preset,
// --frames, into a pipeline::CameraPathArgs (engine/pipeline/camera_path.h).
#pragma once

#include "pipeline/camera_path.h"

#include <CLI/CLI.hpp>

namespace icube::tools {

// `a` must outlive cmd.
void add_camera_path_options(CLI::App* cmd, pipeline::CameraPathArgs& a);

}  // namespace icube::tools
