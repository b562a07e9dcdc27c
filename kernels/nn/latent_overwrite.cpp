// Outpainting's overwrite on the GPU; see latent_overwrite.h.
#include "kernels/nn/latent_overwrite.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

namespace icube::kernels::nn {

LatentOverwrite::LatentOverwrite(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/latent_overwrite")) {}

void LatentOverwrite::record(gpu::CommandList& cmd, uint32_t channels, uint64_t spatial, float sqrt_alpha,
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
  cmd.dispatch(program_, gpu::Threads{count}, pc,
               {x.binding(0, bytes), known.binding(0, bytes), mask.binding(0, spatial * 4), z.binding(0, bytes)});
}

}  // namespace icube::kernels::nn
