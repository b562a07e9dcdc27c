// BatchNorm in inference form (running statistics), as the GSM's conv image
// encoder and Depth-Anything upsampler use it: y = (x - mean) / sqrt(var + eps)
// * weight + bias per channel (axis 1), any spatial rank.
// CPU reference: nn::cpu::batch_norm (batch_norm_cpu.cpp).
#pragma once

#include "kernels/nn/cpu_tensor.h"

namespace icube::nn::cpu {

CpuTensor batch_norm(const CpuTensor& x, const CpuTensor& weight, const CpuTensor& bias, const CpuTensor& running_mean,
                     const CpuTensor& running_var, double eps = 1e-5);

}  // namespace icube::nn::cpu
