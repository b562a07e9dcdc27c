// icube-view's command line (options.cpp): the options, their parsing (CLI11)
// and the window-less --verify mode.
#pragma once

#include "recorder.h"

#include <cstddef>
#include <string>
#include <vector>

namespace icube::viewer {

struct Options {
  std::string input, scene_path, script, record_out = "recording.npy", screenshot_out = "screenshot.png", load;
  int frames = 0, width = 1280, height = 720, interp_frames = kDefaultInterpolatedFrames;
  bool autopilot = false, stats = false, vsync = true, adaptive = false, fly = false, check = false;
  double scale = 1.0, vfov = 35.0, max_seconds = 900.0, target_ms = 45.0;
  double resident_radius = -1.0;  // m; 0 = the whole world on the GPU, < 0 = automatic (app.h)
  std::string mode = "shaded";
  std::string view = "auto";
  // Gaussian view level of detail: {fine within m, cut beyond m} (0 = off); empty = gaussian_view.h's defaults.
  std::vector<double> moving_lod, still_lod;
  double chunk_size = 0.0;  // m; 0 = gaussian_view.h's default  // voxels | gaussians | auto (gaussians when the input has them)
  std::string verify;
  size_t expect_passes = 0;
  std::vector<std::string> compare;  // --compare-semantic VIEWER.png BUFFER.png
  std::vector<std::string> compare_rgb;  // --compare-rgb A.png B.png
  int max_level_diff = 2;            // --compare-rgb: channel levels a pixel may differ by
  double max_mismatch = 0.001;       // fraction of pixels
};

// Parses argv into `o`. Returns -1 to go on, else the exit code (--help, a bad option).
int parse_options(int argc, char** argv, Options& o);

// --compare-semantic: the viewer's semantic PNG against `icube buffers`' semantic_buffer PNG
// (screenshot_check.h compare_semantic); exit 0 when at most max_mismatch of the pixels differ.
int run_compare(const Options& o);
// --compare-rgb: two RGB PNGs of the same size; exit 0 when at most max_mismatch of the pixels
// differ by more than max_level_diff levels in a channel (e.g. the Gaussian view's shot vs `icube splat render`).
int run_compare_rgb(const Options& o);

// --verify: checks a saved trajectory without a window; the exit code.
int run_verify(const Options& o);

}  // namespace icube::viewer
