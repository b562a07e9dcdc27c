// One run of the main job (`icube generate SCENE -o PACKAGE`): scene → Stage 1
// voxel world → Stage 2 guidance buffers and appearance frames → Stage 3
// Gaussians and sky → preview, as one package (docs/generate.md, every path
// from scene/package_layout.h) built in a resumable staging folder
// (package_staging.h) and renamed into place, with a manifest of its inputs,
// options, stages and every file's SHA-256. One function per stage; the CLI
// (tools/cmd_generate.cpp, tools/generate_batch.cpp) parses options and shows
// progress through the callbacks below.
// Tests: tests/pipeline/test_generate_package.cpp (in process: stages,
// resume, staging) and tests/lift/test_generate*.cpp (the command).
#pragma once

#include "pipeline/camera_path.h"

#include "lift/gsm_lift.h"

#include "render/appearance/prompt.h"
#include "scene/input_error.h"

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace icube::pipeline {

struct GenerateArgs {
  CameraPathArgs path;
  std::string world, output, prompt = render::kDefaultAppearancePrompt;
  uint32_t seed = 0;
  size_t key_every = 2;
  int per_cell = 1;
  bool no_video = false;
  // x264 preset of the guidance buffers' three mp4s (InfiniCube's writer: veryslow); the preview's
  // fly-through, for people, is encoded at medium.
  std::string video_preset = "veryslow";
  bool no_preview = false;  // no preview/ (the Gaussians' fly-through)
  // Appearance frames made elsewhere (a video model run on this job's guidance buffers): a PNG folder
  // or an mp4, imported (render/appearance/frames_import.h) instead of the procedural renderer's.
  std::string frames_from;
  // With frames_from: sky masks segmented from those frames (render/appearance/frames_import.h),
  // binary or a label map with sky_label as sky; they let the pixel branch see the mid-ground.
  std::string sky_masks;
  int sky_label = -1;
  size_t pixel_frames = 1;  // Stage 3 pixel branch: the last N key frames (lift_frames.h)
  // Stage 3 with the learned GSM (lift/gsm_lift.h) when gsm.weights is set, else the non-learned lift.
  // gsm_options: its input size, radius and backend (key_every and pixel_frames are the fields above;
  // the scene and the car mesh are the job's). The configuration, the sizes and the weights are checked
  // before any stage.
  lift::GsmModelPaths gsm;
  lift::GsmLiftOptions gsm_options;
  // Skip the package when it is complete and made from the same inputs and
  // options; else continue a killed run's staging folder after its last finished stage.
  bool resume = false;

  // Progress of the running stage's work: (stage, unit, done, total).
  std::function<void(const std::string& stage, const std::string& unit, size_t done, size_t total)> progress;
  // One-line notes for people (a stage's time and result, a resumed run); none when unset.
  std::function<void(const std::string& line)> log;
  // Called right after a stage is recorded as finished (the CLI's kill hook; tests that stop a run).
  std::function<void(const std::string& stage)> on_stage_finished;
};

struct GenerateStage {
  std::string name, detail;
  double seconds = 0.0, peak_rss_mib = 0.0;
  bool resumed = false;  // finished by an earlier run
};

struct GenerateResult {
  std::filesystem::path package;
  std::vector<GenerateStage> stages;
  double seconds = 0.0;
  size_t resumed_stages = 0;
  bool skipped = false;  // --resume found the package complete
};

// The stages in order.
inline const std::vector<std::string>& generate_stage_names() {
  static const std::vector<std::string> names = {"world", "buffers", "frames", "lift", "preview"};
  return names;
}

// Throws (one line naming the file) on bad input; the package is then absent.
GenerateResult generate_package(const GenerateArgs& a, scene::Diagnostics& diag);

}  // namespace icube::pipeline
