// The command line's side of the main job (pipeline/generate_package.h): one
// progress bar per stage, the stage notes on stderr, the ICUBE_GENERATE_KILL_AFTER
// test hook, and the summary table. Used by `icube generate` and its batches.
#pragma once

#include "pipeline/generate_package.h"

#include <string>

namespace icube::tools {

// Sets a's progress, log and on_stage_finished for a terminal (or a CI log).
void report_on_terminal(pipeline::GenerateArgs& a);

// The summary table: seconds and peak RSS per stage, "resumed" for stages an earlier run finished.
void print_generate_summary(const pipeline::GenerateResult& r, const std::string& scene);

}  // namespace icube::tools
