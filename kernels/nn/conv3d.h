// Dense 3-D convolution on the GPU (shaders/nn/conv3d.comp): NCDHW float32,
// kernel 1 or 3, stride 1, zero padding kernel/2 (sizes kept), with bias —
// the convolutions of the diffusion UNet's ResBlocks, input and output heads
// and 1x1 skips. Weights are packed once on the host (pack_conv3d_weights) into
// [in_channels * k^3][out_channels padded to 8] so a workgroup reads its 8 output
// channels of one tap as two vec4s.
//
// Each of x, y and the packed weights must fit one storage-buffer binding
// (lavapipe: 128 MiB; the released model's 64^3 x 192 activations do not, and
// will be split by the network engine); record() throws std::invalid_argument
// naming the tensor otherwise.
// CPU reference: nn::cpu::conv3d (layers_cpu.h). Tests: tests/nn/test_conv3d_gpu.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

struct Conv3dShape {
  uint32_t batch = 1, in_channels = 1, out_channels = 1;
  uint32_t x = 1, y = 1, z = 1;
  uint32_t kernel = 3;  // 1 or 3
  uint64_t voxels() const { return uint64_t{x} * y * z; }
  uint64_t flops() const;  // 2 * B * Co * Ci * k^3 * voxels (padding taps counted)
};

// [Co, Ci, k, k, k] row-major -> [Ci * k^3][ceil(Co / 8) * 8] (zeros in the padding).
std::vector<float> pack_conv3d_weights(const std::vector<float>& w, uint32_t out_channels, uint32_t in_channels,
                                       uint32_t kernel);

class Conv3d {
 public:
  explicit Conv3d(gpu::Context& ctx);
  // Records y = conv3d(x, w) + bias; `bias` may be nullptr. The caller orders
  // x / weights before and y after (no barrier inside).
  void record(gpu::CommandList& cmd, const Conv3dShape& s, const gpu::Buffer& x, const gpu::Buffer& packed_weights,
              const gpu::Buffer* bias, const gpu::Buffer& y);

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
};

}  // namespace icube::kernels::nn
