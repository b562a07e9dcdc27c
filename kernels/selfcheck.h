// `icube selfcheck`: runs every primitive kernel on the selected device on
// fixed-seed inputs and compares with its CPU reference.
#pragma once

#include "gpu/context.h"

#include <string>
#include <vector>

namespace icube::kernels {

struct SelfCheckResult {
  std::string name;
  bool passed = false;
  std::string detail;  // sizes, first mismatch, or the error
  double milliseconds = 0.0;
};

std::vector<SelfCheckResult> run_selfcheck(gpu::Context& ctx);

}  // namespace icube::kernels
