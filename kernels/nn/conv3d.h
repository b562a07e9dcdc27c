// Dense 3-D convolution on the GPU: NCDHW float32,
// kernel 1 or 3, stride 1, zero padding kernel/2 (sizes kept), with bias —
// the convolutions of the diffusion UNet's ResBlocks, input and output heads
// and 1x1 skips. Three kernels (Conv3dPath): the register tile for lavapipe
// (shaders/nn/conv3d.comp), a shared-memory implicit GEMM for GPUs
// (conv3d_tiled.comp) and its tensor-core form (conv3d_coopmat.comp), all on the
// same bindings, windows and push constants. Weights are packed once on the host (pack_conv3d_weights) into
// [in_channels * k^3][out_channels padded to 8] so a workgroup reads its 8 output
// channels of one tap as two vec4s. The input is bound as an R32_SFLOAT texel
// buffer (texel_window in buffer_checks.h; R16_SFLOAT when it is stored as
// fp16, Conv3dShape::f16_input), the rest as storage buffers.
//
// x and y may exceed one storage-buffer binding (lavapipe: 128 MiB; the
// released model's 64^3 x 192 activations are 192 MiB): record() then splits
// the work into windows of one batch element, whole 8-channel output blocks
// and as many input channels as fit, each bound at its (alignment-rounded)
// offset, later input windows accumulating into y after an explicit
// compute-to-compute barrier inside record(). The packed weights must fit one
// binding (768 -> 768 channels, 3^3: 64 MiB). Tested with a forced small limit
// and with real 136 MB tensors over lavapipe's 128 MiB binding.
// CPU reference: nn::cpu::conv3d (below, conv3d_cpu.cpp). Tests: tests/nn/test_conv3d.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"
#include "kernels/nn/cpu_tensor.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace icube::gpu {
struct DeviceInfo;
}

namespace icube::kernels::nn {

// Which kernel runs a convolution. Chosen per device and precision when recorded
// (default_conv3d_path); tests and benchmarks may force one (Conv3d::force_path).
enum class Conv3dPath {
  kRegisterTile,        // nn/conv3d*.comp: CPU devices (lavapipe): register tiles, texel gathers, no shared memory
  kSharedTile,          // nn/conv3d_tiled*.comp: GPUs: shared-memory implicit GEMM, fp32 FMA
  kCoopMatrix,          // nn/conv3d_coopmat*.comp: NVIDIA tensor cores (fp16 operands, fp32 sums)
  kCoopMatrixEmulated,  // nn/conv3d_coopmat_emulated*.comp: the same tiling written out per lane (tests)
};
const char* conv3d_path_name(Conv3dPath path);
// Why `path` cannot run on `device` ("" when it can): the cooperative-matrix kernels need
// VK_NV_cooperative_matrix and subgroups of 32, their emulation shaderFloat16. Conv3d and SparseConv3d.
std::string conv3d_path_unavailable(Conv3dPath path, const gpu::DeviceInfo& device);
// Whether `path` rounds its activations to fp16 too (the cooperative-matrix kernels' fp16 operands, fp32 sums),
// not only the weights it is given.
bool conv3d_path_rounds_activations(Conv3dPath path);

// lavapipe's kernel family (CPU devices, or ICUBE_NN_KERNELS=lavapipe: kernels/nn/kernel_family.h): the
// register tile. The GPUs' family: with fp16 weights the cooperative-matrix kernel where the device has it
// (DeviceInfo::cooperative_matrix_nv, subgroups of 32), else the shared tile.
Conv3dPath default_conv3d_path(const gpu::DeviceInfo& device, bool f16_weights);

struct Conv3dShape {
  uint32_t batch = 1, in_channels = 1, out_channels = 1;
  uint32_t x = 1, y = 1, z = 1;
  uint32_t kernel = 3;  // 1 or 3
  bool f16_weights = false;  // packed weights as fp16 (pack_conv3d_weights_f16; nn/conv3d_f16w.comp)
  bool f16_input = false;    // x stored as fp16 (an R16_SFLOAT texel view: every path reads it unchanged)
  uint64_t voxels() const { return uint64_t{x} * y * z; }
  uint64_t flops() const;  // 2 * B * Co * Ci * k^3 * voxels (padding taps counted)
};

// [Co, Ci, k, k, k] row-major -> [Ci * k^3][ceil(Co / 8) * 8] (zeros in the padding).
std::vector<float> pack_conv3d_weights(const std::vector<float>& w, uint32_t out_channels, uint32_t in_channels,
                                       uint32_t kernel);

// The same layout in fp16 (round to nearest even): half the weight memory and bandwidth.
std::vector<uint16_t> pack_conv3d_weights_f16(const std::vector<float>& w, uint32_t out_channels,
                                              uint32_t in_channels, uint32_t kernel);

class Conv3d {
 public:
  explicit Conv3d(gpu::Context& ctx);
  // Records y = conv3d(x, w) + bias; `bias` may be nullptr. The caller orders
  // x / weights before and y after; the only barriers inside are those between
  // input-channel windows (above).
  void record(gpu::CommandList& cmd, const Conv3dShape& s, const gpu::Buffer& x, const gpu::Buffer& packed_weights,
              const gpu::Buffer* bias, const gpu::Buffer& y);

  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit), to exercise the windows cheaply.
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }
  // Tests and benchmarks: run every convolution on `path` (nullopt: default_conv3d_path).
  void force_path(std::optional<Conv3dPath> path) { forced_path_ = path; }
  // The path record() takes for weights of this precision, and the shader that runs it.
  Conv3dPath path(bool f16_weights) const;
  static const char* shader_name(Conv3dPath path, bool f16_weights);

 private:
  gpu::Program& program(Conv3dPath path, uint32_t kernel, bool f16_weights);
  gpu::Context& ctx_;
  uint64_t max_binding_bytes_ = 0;
  std::optional<Conv3dPath> forced_path_;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// conv3d: x [B, Ci, X, Y, Z], w [Co, Ci, k, k, k] (or [Co, Ci] / [Co, Ci, 1] for 1x1), bias [Co]; zero
// padding, output size floor((n + 2p - k) / s) + 1 (PyTorch's Conv3d). linear: y = x W^T + b, W [out, in],
// over the last axis.
CpuTensor conv3d(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias, int stride = 1, int padding = 1);
CpuTensor linear(const CpuTensor& x, const CpuTensor& w, const CpuTensor* bias);

}  // namespace icube::nn::cpu
