// Sampler latent updates host module; see sampler_step.h.
#include "nn/sampler_step.h"

#include "gpu/context.h"
#include "nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <stdexcept>

namespace icube::kernels::nn {

SamplerStep::SamplerStep(gpu::Context& ctx)
    : ctx_(ctx), step_(ctx.program("nn/ddim_step")), overwrite_(ctx.program("nn/latent_overwrite")) {}

void SamplerStep::step(gpu::CommandList& cmd, const DdimStepCoefficients& c, uint64_t count, const gpu::Buffer& x,
                       const gpu::Buffer& v_cond, const gpu::Buffer* v_uncond, float cfg_scale, const gpu::Buffer* z,
                       const gpu::Buffer& out) {
  if (count == 0) return;
  const bool noise = c.sigma != 0.0f;
  if (noise && !z) throw std::invalid_argument("ddim_step: sigma " + std::to_string(c.sigma) + " without a noise buffer");
  require_one_binding(ctx_, "ddim_step", "latent", count);
  const uint64_t bytes = count * 4;
  require_buffer("ddim_step", "x", bytes, x);
  require_buffer("ddim_step", "conditional prediction", bytes, v_cond);
  if (v_uncond) require_buffer("ddim_step", "unconditional prediction", bytes, *v_uncond);
  if (noise) require_buffer("ddim_step", "noise", bytes, *z);
  require_buffer("ddim_step", "output", bytes, out);
  shader::DdimStepParams pc{static_cast<uint32_t>(count),
                            (v_uncond ? NN_DDIM_FLAG_CFG : 0u) | (noise ? NN_DDIM_FLAG_NOISE : 0u),
                            cfg_scale,
                            c.sqrt_alpha,
                            c.sqrt_beta,
                            c.sqrt_alpha_prev,
                            c.direction,
                            c.sigma};
  cmd.dispatch(step_, gpu::Threads{count}, pc,
               {x.binding(0, bytes), v_cond.binding(0, bytes), v_uncond ? v_uncond->binding(0, bytes) : gpu::null_binding(),
                noise ? z->binding(0, bytes) : gpu::null_binding(), out.binding(0, bytes)});
}

void SamplerStep::overwrite_known(gpu::CommandList& cmd, uint32_t channels, uint64_t spatial, float sqrt_alpha,
                                  float sqrt_beta, const gpu::Buffer& known, const gpu::Buffer& mask, const gpu::Buffer& z,
                                  const gpu::Buffer& x) {
  const uint64_t count = uint64_t{channels} * spatial;
  if (count == 0) return;
  require_one_binding(ctx_, "latent_overwrite", "latent", count);
  const uint64_t bytes = count * 4;
  require_buffer("latent_overwrite", "known latents", bytes, known);
  require_buffer("latent_overwrite", "mask", spatial * 4, mask);
  require_buffer("latent_overwrite", "noise", bytes, z);
  require_buffer("latent_overwrite", "x", bytes, x);
  shader::LatentOverwriteParams pc{static_cast<uint32_t>(count), static_cast<uint32_t>(spatial), sqrt_alpha, sqrt_beta};
  cmd.dispatch(overwrite_, gpu::Threads{count}, pc,
               {x.binding(0, bytes), known.binding(0, bytes), mask.binding(0, spatial * 4), z.binding(0, bytes)});
}

}  // namespace icube::kernels::nn
