// Outpainting's overwrite on the GPU; see latent_overwrite.h.
#include "kernels/nn/latent_overwrite.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

LatentOverwrite::LatentOverwrite(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/latent_overwrite")) {}

void LatentOverwrite::record(gpu::CommandList& cmd, uint32_t channels, uint64_t spatial, float sqrt_alpha,
                             float sqrt_beta, const gpu::Buffer& known, const gpu::Buffer& mask, const gpu::Buffer& z,
                                  const gpu::Buffer& x) {
  const uint64_t count = uint64_t{channels} * spatial;
  if (count == 0) return;
  const uint64_t bytes = count * 4;
  require_buffer("latent_overwrite", "known latents", bytes, known);
  require_buffer("latent_overwrite", "mask", spatial * 4, mask);
  require_buffer("latent_overwrite", "noise", bytes, z);
  require_buffer("latent_overwrite", "x", bytes, x);
  // The latent over one binding goes in windows of elements, the same range of x, known and z
  // (disjoint writes, no barrier between them). A mask that fits one binding is bound whole and
  // windows may span channels; a larger one goes in windows too, then no window leaves its channel
  // and each binds the mask's voxels it covers.
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  if (spatial > UINT32_MAX || count > UINT32_MAX)
    throw std::invalid_argument("latent_overwrite: a latent of " + std::to_string(count) + " values exceeds 32-bit indices");
  const bool mask_windows = spatial > fit;
  shader::LatentOverwriteParams pc{0, static_cast<uint32_t>(spatial), sqrt_alpha, sqrt_beta, 0, 0, 0, 0};
  for (uint64_t first = 0; first < count;) {
    const uint64_t voxel = first % spatial;
    const uint64_t n = mask_windows ? std::min(fit, spatial - voxel) : std::min(fit, count - first);
    gpu::BufferBinding mb = mask.binding(0, spatial * 4);
    pc.mask_base = 0;
    if (mask_windows) {
      const ElementWindow mw = element_window(ctx_, mask, voxel, n);
      mb = mw.binding;
      pc.mask_base = static_cast<uint32_t>(voxel - mw.offset);
    }
    const ElementWindow xw = element_window(ctx_, x, first, n);
    pc.count = static_cast<uint32_t>(n);
    pc.first = static_cast<uint32_t>(first);
    pc.offset = xw.offset;
    cmd.dispatch(program_, gpu::Threads{n}, pc,
                 {xw.binding, element_window(ctx_, known, first, n).binding, mb, element_window(ctx_, z, first, n).binding});
    first += n;
  }
}

}  // namespace icube::kernels::nn
