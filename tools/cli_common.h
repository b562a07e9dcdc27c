// What every icube subcommand does the same way: warnings to stderr (at most
// 50 shown), any error as one line "icube: error: ..." and exit status 1
// (CLI::RuntimeError, which main's app.exit() turns into the status), and a
// refusal to overwrite a command's own input.
#pragma once

#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace icube::tools {

inline void print_warnings(const scene::Diagnostics& diag) {
  constexpr size_t kMaxShown = 50;
  for (size_t i = 0; i < diag.warnings.size() && i < kMaxShown; ++i)
    std::fprintf(stderr, "icube: warning: %s\n", diag.warnings[i].c_str());
  if (diag.warnings.size() > kMaxShown)
    std::fprintf(stderr, "icube: warning: ... and %zu more warnings\n", diag.warnings.size() - kMaxShown);
}

// Runs body(diag): its warnings go to stderr, any exception becomes one line and exit status 1.
template <class F>
void run_command(F&& body) {
  scene::Diagnostics diag;
  try {
    body(diag);
  } catch (const std::exception& e) {
    print_warnings(diag);
    std::fprintf(stderr, "icube: error: %s\n", e.what());
    throw CLI::RuntimeError(1);
  }
  print_warnings(diag);
}

using scene::refuse_overwriting_input;  // scene/atomic_file.h

// --sky-masks DIR and --sky-label N (render/appearance/frames_import.h), shared by `icube frames
// import` and `icube generate`; `what` says which frames the masks were segmented from.
inline void add_sky_mask_options(CLI::App* cmd, std::string& masks, int& label, const std::string& what) {
  cmd->add_option("--sky-masks", masks,
                  "Sky masks segmented from " + what +
                      " (one PNG per frame, sorted by name; e.g. SegFormer on the frames) instead of the buffers' sky, "
                      "so Stage 3 lifts what the video model drew beyond the voxel world")
      ->type_name("MASK_DIR");
  cmd->add_option("--sky-label", label,
                  "The masks are 8-bit gray label maps and this value is sky (Cityscapes: 10); default: binary masks, "
                  "gray >= 128 = sky")
      ->type_name("N")
      ->check(CLI::Range(0, 255));
}

}  // namespace icube::tools
