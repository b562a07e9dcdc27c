// Named intermediates of a GSM forward, under the reference case's names
// (../shared/data/models/gsm_small/intermediates.safetensors): a stage records
// what it computed when given a trace, so a test or `icube nn gsm forward
// --dump-layers` finds the first stage that differs.
#pragma once

#include "kernels/nn/cpu_tensor.h"

#include <map>
#include <string>

namespace icube::nn {

struct GsmTrace {
  std::map<std::string, CpuTensor> tensors;
};

inline void trace_put(GsmTrace* trace, const std::string& name, const CpuTensor& x) {
  if (trace) trace->tensors[name] = x;
}

}  // namespace icube::nn
