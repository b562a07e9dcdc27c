// 2-D resampling of [B, C, H, W] maps with PyTorch's F.interpolate semantics
// (to an output size; no antialiasing): bilinear with or without corner
// alignment, bicubic (a = -0.75, border-clamped taps, as PyTorch), and
// nearest (source index floor(dst * in / out)). The GSM resizes its images,
// Depth-Anything's position grid and features with them.
// CPU reference: nn::cpu::resize_* (interpolate_cpu.cpp).
#pragma once

#include "kernels/nn/cpu_tensor.h"

namespace icube::nn::cpu {

// align_corners false: src = (dst + 0.5) * in / out - 0.5, clamped at 0 below; true: src = dst * (in - 1) / (out - 1).
CpuTensor resize_bilinear(const CpuTensor& x, int64_t out_h, int64_t out_w, bool align_corners);
CpuTensor resize_bicubic(const CpuTensor& x, int64_t out_h, int64_t out_w, bool align_corners);
CpuTensor resize_nearest(const CpuTensor& x, int64_t out_h, int64_t out_w);

}  // namespace icube::nn::cpu
