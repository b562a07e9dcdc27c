// 2-D convolutions of the GSM's image networks (the conv image encoder, the
// Depth-Anything neck and fusion, the sky patch embedding, x-unet's frame-1
// convolutions): PyTorch's Conv2d (any kernel, stride, zero padding, optional
// bias) and ConvTranspose2d (the DPT neck's x4 / x2 up-projections).
// CPU reference: nn::cpu::conv2d / conv_transpose2d (conv2d_cpu.cpp, double
// accumulation). The GPU kernel comes with the GSM's GPU module.
#pragma once

#include "kernels/nn/cpu_tensor.h"

namespace icube::nn::cpu {

// x [B, Ci, H, W], w [Co, Ci, kh, kw], bias [Co] or nullptr. Output [B, Co, (H + 2p - kh) / s + 1, (W + 2p - kw) / s + 1].
CpuTensor conv2d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride = 1, int padding = 0);
// ConvTranspose2d: x [B, Ci, H, W], w [Ci, Co, kh, kw] (PyTorch's layout), bias [Co] or nullptr.
// Output [B, Co, (H - 1) s - 2p + kh, (W - 1) s - 2p + kw].
CpuTensor conv_transpose2d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride, int padding = 0);

}  // namespace icube::nn::cpu
