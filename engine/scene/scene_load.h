// Opens any supported scene file by content: the project's JSON, a Waymo
// Scenario TFRecord, or an OpenDRIVE map.
#pragma once

#include "scene/input_error.h"
#include "scene/opendrive_reader.h"
#include "scene/scene.h"

#include <string>

namespace icube::scene {

enum class SceneFormat { IcubeJson, WaymoTfRecord, OpenDrive, Unknown };

struct LoadOptions {
  std::string waymo_selector;  // record index or scenario id ("" = first)
  OpenDriveOptions opendrive;
};

// Sniffs the first bytes (and the extension as a hint).
SceneFormat detect_scene_format(const std::string& path);
const char* scene_format_name(SceneFormat f);

Scene load_scene(const std::string& path, const LoadOptions& options = {}, Diagnostics* diag = nullptr);

}  // namespace icube::scene
