// Outpainting's overwrite of the known cells of a latent on the GPU
// (shaders/nn/latent_overwrite.comp): x[c][v] = sqrt_alpha known[c][v] +
// sqrt_beta z[c][v] where mask[v] != 0 (mask: uint32 per voxel), every channel.
// With sqrt_beta 0 and z = known the cells get the known latents exactly. No
// barrier inside: the caller orders the overwrite before the next denoiser
// call. A latent over one storage binding runs in windows of elements (the
// mask, one channel's voxels, bound whole where it fits one binding, else in
// windows inside each channel).
// CPU reference (below, latent_overwrite_cpu.cpp): nn::cpu::latent_overwrite.
// Tests: tests/nn/test_latent_overwrite.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace icube::kernels::nn {

class LatentOverwrite {
 public:
  explicit LatentOverwrite(gpu::Context& ctx);
  void record(gpu::CommandList& cmd, uint32_t channels, uint64_t spatial, float sqrt_alpha, float sqrt_beta,
              const gpu::Buffer& known, const gpu::Buffer& mask, const gpu::Buffer& z, const gpu::Buffer& x);

  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// x [channels][spatial]: the masked cells set to sqrt_alpha known + sqrt_beta z, or to known itself when z
// is null.
void latent_overwrite(std::vector<float>& x, const std::vector<uint32_t>& mask, const std::vector<float>& known,
                      float sqrt_alpha, float sqrt_beta, const std::vector<float>* z);

}  // namespace icube::nn::cpu
