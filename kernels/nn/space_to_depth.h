// x-unet's Downsample: a 2x2 space-to-depth ('b c f (h s1) (w s2) -> b (c s1 s2)
// f h w', so [B, C, H, W] -> [B, 4C, H/2, W/2] with channel c * 4 + dy * 2 +
// dx) followed by a 1x1 conv [Co, 4C]. On the GPU both run as ONE conv2d
// (kernels/nn/conv2d.h) with kernel 2, stride 2, no padding: output (i, j) of
// that conv sums w2[o, c, dy, dx] x[c, 2i + dy, 2j + dx], which is the 1x1
// conv of the rearranged map when w2[o, c, dy, dx] = w1[o, c * 4 + dy * 2 + dx]
// (space_to_depth_conv_weights). The 4C-channel map is never written, and
// every input is read once. (In row-major memory that permutation is the
// identity: [Co, 4C] read as [Co, C, 2, 2]; the helper states it explicitly.)
// CPU reference of the rearrangement: nn::cpu::space_to_depth
// (space_to_depth_cpu.cpp). Tests: tests/nn/test_space_to_depth.cpp (the
// equivalence, on the GPU, and gsm_small's pix.unet.downs.*.3).
#pragma once

#include "kernels/nn/conv2d.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

// The Downsample's 1x1 conv weight w1 [Co, 4C] (any trailing unit axes: x-unet's [Co, 4C, 1, 1, 1]) as the
// equivalent 2x2 stride-2 conv weight [Co, C, 2, 2]: w2[o, c, dy, dx] = w1[o, c * 4 + dy * 2 + dx].
std::vector<float> space_to_depth_conv_weights(const std::vector<float>& w1, uint32_t out_channels, uint32_t in_channels);

// The conv2d that runs space-to-depth + 1x1: x [batch, in_channels, H, W] (H, W even) -> [batch, out_channels, H/2, W/2].
Conv2dShape space_to_depth_conv_shape(uint32_t batch, uint32_t in_channels, uint32_t out_channels, uint32_t height,
                                      uint32_t width);

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// [B, C, H, W] (H, W even) -> [B, 4C, H/2, W/2]: y[b, c * 4 + dy * 2 + dx, i, j] = x[b, c, 2i + dy, 2j + dx].
CpuTensor space_to_depth(const CpuTensor& x);

}  // namespace icube::nn::cpu
