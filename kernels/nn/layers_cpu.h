// Plain-loop CPU references of the network layers: the oracles of the GPU
// kernels in kernels/nn/ (conv3d, group_norm, layer_norm, attention, elementwise)
// and the building blocks of the whole-network references (engine/nn/unet_reference.h,
// vae_reference.h).
// Conventions are PyTorch's, as the official modules use them:
//   conv3d      x [B, Ci, X, Y, Z], w [Co, Ci, k, k, k] (or [Co, Ci] / [Co, Ci, 1] for 1x1), bias [Co];
//               zero padding, output size floor((n + 2p - k) / s) + 1
//   group_norm  biased variance over (C/G) x spatial per group, eps inside the sqrt, affine per channel
//   layer_norm  over the last axis, biased variance, eps 1e-5 default
//   linear      y = x W^T + b, W [out, in], over the last axis
//   attention   q, k, v [B, H, N, D]: softmax(q k^T * scale) v, scale = 1/sqrt(D)
//   gelu        exact (erf), as F.gelu's default
//   avg_pool2   2x2x2 mean, stride 2, sizes floored; upsample2 nearest x2
//   timestep_embedding  [cos(t f), sin(t f)], f_i = exp(-ln(10000) i / half), in float32 as upstream
// Sums are accumulated in double, so the references sit closer to exact than
// any float32 implementation they judge. Tests: tests/nn/test_layers_cpu.cpp.
#pragma once

#include "nn/cpu_tensor.h"

#include <cstdint>
#include <vector>

namespace icube::nn::cpu {

CpuTensor conv3d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride = 1, int padding = 1);
CpuTensor group_norm(const CpuTensor& x, int groups, const CpuTensor& weight, const CpuTensor& bias, double eps);
CpuTensor layer_norm(const CpuTensor& x, const CpuTensor& weight, const CpuTensor& bias, double eps = 1e-5);
CpuTensor linear(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias);
CpuTensor attention(const CpuTensor& q, const CpuTensor& k, const CpuTensor& v);
CpuTensor silu(CpuTensor x);
CpuTensor gelu(CpuTensor x);
CpuTensor add(CpuTensor a, const CpuTensor& b);  // same shapes
// h * (1 + scale[b, c]) + shift[b, c] over the spatial axes of h [B, C, ...]; ss [B, 2C] = (scale, shift).
CpuTensor scale_shift(CpuTensor h, const CpuTensor& ss);
// h + e[b, c] over the spatial axes; e [B, C].
CpuTensor add_channel_bias(CpuTensor h, const CpuTensor& e);
CpuTensor avg_pool2(const CpuTensor& x);
CpuTensor upsample2(const CpuTensor& x);
CpuTensor concat_channels(const CpuTensor& a, const CpuTensor& b);
CpuTensor timestep_embedding(const std::vector<int64_t>& t, int dim, double max_period = 10000.0);

// The project's agreement metric for networks: max |got - ref| / std(ref) (population std, in double).
double max_abs_over_std(const std::vector<float>& got, const std::vector<float>& ref);

}  // namespace icube::nn::cpu
