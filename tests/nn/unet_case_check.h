// Runs a UNet forward (CPU reference or GPU) on the official unet_small
// reference case and checks the output and every captured block against it
// (max |y - y_ref| / std(y_ref) <= 1e-4); shared by tests/nn/test_unet_*.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"
#include "nn/safetensors.h"
#include "nn/unet_reference.h"
#include "world/npy.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <functional>
#include <string>

namespace icube::test {

struct UNetCaseResult {
  double output = 0.0, worst_block = 0.0;
  size_t blocks = 0;
};

// `forward(x, t, capture)` runs the network; `dir` is models/unet_small/ (with the slash).
inline UNetCaseResult check_unet_small_case(
    const std::string& dir,
    const std::function<nn::CpuTensor(const nn::CpuTensor&, const std::vector<int64_t>&, const nn::UNetReference::Capture&)>&
        forward) {
  const world::NpyArray x = world::read_npy(dir + "case_1.x.npy"), t = world::read_npy(dir + "case_1.t.npy"),
                        y = world::read_npy(dir + "case_1.out.npy");
  const nn::SafetensorsFile inter(dir + "case_1.intermediates.safetensors");
  UNetCaseResult r;
  const nn::CpuTensor out = forward(nn::CpuTensor(std::vector<int64_t>(x.shape.begin(), x.shape.end()), x.values<float>()),
                                    t.values<int64_t>(), [&](const std::string& name, const nn::CpuTensor& v) {
                                      const nn::TensorInfo* ref = inter.find(name);
                                      REQUIRE_MESSAGE(ref != nullptr, name);
                                      CHECK(ref->shape == v.shape);
                                      const double e = nn::cpu::max_abs_over_std(v.data, inter.to_f32(*ref));
                                      INFO(name << ": max |y - y_ref| / std = " << e);
                                      CHECK(e <= 1e-4);
                                      r.worst_block = std::max(r.worst_block, e);
                                      ++r.blocks;
                                    });
  CHECK(r.blocks == inter.tensors().size());
  CHECK(out.shape == std::vector<int64_t>(y.shape.begin(), y.shape.end()));
  r.output = nn::cpu::max_abs_over_std(out.data, y.values<float>());
  CHECK(r.output <= 1e-4);
  return r;
}

}  // namespace icube::test
