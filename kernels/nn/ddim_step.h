// One DDIM step of the sampler on the GPU (shaders/nn/ddim_step.comp): a
// v-prediction with optional classifier-free guidance and step noise, float32
// in the reference's operation order. Coefficients come from the caller (the
// schedule lives in engine/diffusion/ddim_schedule.h); no barrier inside: the
// caller orders the denoiser's output before record(). A latent over one
// storage binding runs in windows of elements.
// CPU references (below, ddim_step_cpu.cpp): nn::cpu::ddim_step, cfg_combine.
// Tests: tests/nn/test_ddim_step.cpp.
#pragma once

#include "gpu/buffer.h"
#include "gpu/commands.h"

#include <cstddef>
#include <cstdint>

namespace icube::kernels::nn {

struct DdimStepCoefficients {
  float sqrt_alpha = 0, sqrt_beta = 0, sqrt_alpha_prev = 0, direction = 0, sigma = 0;
};

class DdimStep {
 public:
  explicit DdimStep(gpu::Context& ctx);
  // out = step(x, v) with v = cond + cfg_scale (cond - uncond) when uncond is given; z is read when
  // sigma != 0 (then required). out may not alias x or the predictions.
  void record(gpu::CommandList& cmd, const DdimStepCoefficients& c, uint64_t count, const gpu::Buffer& x,
              const gpu::Buffer& v_cond, const gpu::Buffer* v_uncond, float cfg_scale, const gpu::Buffer* z,
              const gpu::Buffer& out);

  // Tests: pretend one binding holds at most `bytes` (0 = the device's limit).
  void set_max_binding_bytes(uint64_t bytes) { max_binding_bytes_ = bytes; }

 private:
  gpu::Context& ctx_;
  gpu::Program& program_;
  uint64_t max_binding_bytes_ = 0;
};

}  // namespace icube::kernels::nn

namespace icube::nn::cpu {

// x0 = sqrt_alpha x - sqrt_beta v; eps = sqrt_alpha v + sqrt_beta x;
// out = sqrt_alpha_prev x0 + direction eps (+ sigma z): n elements, float32 in this order. z may be null
// when sigma is 0.
void ddim_step(const kernels::nn::DdimStepCoefficients& c, const float* x, const float* v, const float* z, float* out,
               size_t n);
// Classifier-free guidance, InfiniCube's form: cond + scale * (cond - uncond) (conventions §9.2).
void cfg_combine(const float* cond, const float* uncond, float scale, float* out, size_t n);

}  // namespace icube::nn::cpu
