// One DDIM step on the GPU; see ddim_step.h.
#include "kernels/nn/ddim_step.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace icube::kernels::nn {

DdimStep::DdimStep(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/ddim_step")) {}

void DdimStep::record(gpu::CommandList& cmd, const DdimStepCoefficients& c, uint64_t count, const gpu::Buffer& x,
                      const gpu::Buffer& v_cond, const gpu::Buffer* v_uncond, float cfg_scale, const gpu::Buffer* z,
                      const gpu::Buffer& out) {
  if (count == 0) return;
  const bool noise = c.sigma != 0.0f;
  if (noise && !z) throw std::invalid_argument("ddim_step: sigma " + std::to_string(c.sigma) + " without a noise buffer");
  const uint64_t bytes = count * 4;
  require_buffer("ddim_step", "x", bytes, x);
  require_buffer("ddim_step", "conditional prediction", bytes, v_cond);
  if (v_uncond) require_buffer("ddim_step", "unconditional prediction", bytes, *v_uncond);
  if (noise) require_buffer("ddim_step", "noise", bytes, *z);
  require_buffer("ddim_step", "output", bytes, out);
  shader::DdimStepParams pc{0,
                            (v_uncond ? NN_DDIM_FLAG_CFG : 0u) | (noise ? NN_DDIM_FLAG_NOISE : 0u),
                            cfg_scale,
                            c.sqrt_alpha,
                            c.sqrt_beta,
                            c.sqrt_alpha_prev,
                            c.direction,
                            c.sigma,
                            0};
  // A latent over one binding: windows of elements, the same range of every operand (disjoint outputs,
  // no barrier between them).
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  for (uint64_t first = 0; first < count; first += fit) {
    const uint64_t n = std::min(fit, count - first);
    const ElementWindow xw = element_window(ctx_, x, first, n);
    auto window = [&](const gpu::Buffer* b) { return b ? element_window(ctx_, *b, first, n).binding : gpu::null_binding(); };
    pc.count = static_cast<uint32_t>(n);
    pc.offset = xw.offset;
    cmd.dispatch(program_, gpu::Threads{n}, pc,
                 {xw.binding, window(&v_cond), window(v_uncond), window(noise ? z : nullptr), window(&out)});
  }
}

}  // namespace icube::kernels::nn
