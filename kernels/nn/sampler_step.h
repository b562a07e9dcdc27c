// The sampler's latent updates on the GPU: one DDIM step on a v-prediction
// with optional classifier-free guidance and step noise
// (shaders/nn/ddim_step.comp), and outpainting's overwrite of the known cells
// (shaders/nn/latent_overwrite.comp). Coefficients come from the caller (the
// schedule lives in engine/diffusion); no barrier inside: the caller orders
// the UNet's output before step() and the overwrite before the next UNet call.
// Latents must fit one storage binding (a 64^3 x 8 chunk latent is 8 MiB).
// CPU reference: diffusion::ddim_step_cpu / cfg_combine_cpu.
// Tests: tests/diffusion/test_sampler_step_gpu.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstdint>

namespace icube::kernels::nn {

struct DdimStepCoefficients {
  float sqrt_alpha = 0, sqrt_beta = 0, sqrt_alpha_prev = 0, direction = 0, sigma = 0;
};

class SamplerStep {
 public:
  explicit SamplerStep(gpu::Context& ctx);
  // out = step(x, v) with v = cond + cfg_scale (cond - uncond) when uncond is given; z is read when
  // sigma != 0 (then required). out may not alias x or the predictions.
  void step(gpu::CommandList& cmd, const DdimStepCoefficients& c, uint64_t count, const gpu::Buffer& x,
            const gpu::Buffer& v_cond, const gpu::Buffer* v_uncond, float cfg_scale, const gpu::Buffer* z,
            const gpu::Buffer& out);
  // x[c][v] = sqrt_alpha known[c][v] + sqrt_beta z[c][v] where mask[v] != 0 (mask: uint32 per voxel).
  void overwrite_known(gpu::CommandList& cmd, uint32_t channels, uint64_t spatial, float sqrt_alpha, float sqrt_beta,
                       const gpu::Buffer& known, const gpu::Buffer& mask, const gpu::Buffer& z, const gpu::Buffer& x);

 private:
  gpu::Context& ctx_;
  gpu::Program& step_;
  gpu::Program& overwrite_;
};

}  // namespace icube::kernels::nn
