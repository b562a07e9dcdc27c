// The project's own scene format: versioned JSON (docs/scene-format.md).
// Writing then reading is lossless (doubles round-trip exactly).
#pragma once

#include "scene/input_error.h"
#include "scene/scene.h"

#include <string>

namespace icube::scene {

inline constexpr int kSceneJsonVersion = 1;

std::string scene_to_json(const Scene& scene);
// Throws InputError naming `file` and the JSON path of the bad value ("tracks[3].states[7].center").
Scene scene_from_json(const std::string& text, const std::string& file, Diagnostics* diag = nullptr);

// Atomic: writes to a temporary name in the same folder, then renames.
void write_scene_json(const Scene& scene, const std::string& path);
Scene read_scene_json(const std::string& path, Diagnostics* diag = nullptr);

}  // namespace icube::scene
