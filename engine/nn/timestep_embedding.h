// The diffusion UNet's sinusoidal timestep embedding as upstream computes it:
// [cos(t f), sin(t f)], f_i = exp(-ln(max_period) i / half), in float32 (a zero
// column appended for an odd dim). Made on the host for the CPU reference and
// the GPU UNet alike. Tests: tests/nn/test_unet_reference.cpp.
#pragma once

#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <vector>

namespace icube::nn::cpu {

CpuTensor timestep_embedding(const std::vector<int64_t>& t, int dim, double max_period = 10000.0);

}  // namespace icube::nn::cpu
