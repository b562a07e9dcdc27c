// One DPM-Solver++ step on the GPU; see dpm_solver_step.h.
#include "kernels/nn/dpm_solver_step.h"

#include "gpu/context.h"
#include "kernels/nn/buffer_checks.h"
#include "shared/nn_params.h"

#include <algorithm>
#include <stdexcept>

namespace icube::kernels::nn {

DpmSolverStep::DpmSolverStep(gpu::Context& ctx) : ctx_(ctx), program_(ctx.program("nn/dpm_solver_step")) {}

void DpmSolverStep::record(gpu::CommandList& cmd, const DpmSolverStepCoefficients& c, uint64_t count,
                           const gpu::Buffer& x, const gpu::Buffer& v_cond, const gpu::Buffer* v_uncond,
                           float cfg_scale, const gpu::Buffer* x0_prev, const gpu::Buffer& out,
                           const gpu::Buffer& x0_out) {
  if (count == 0) return;
  if (c.second_order() && !x0_prev)
    throw std::invalid_argument("dpm_solver_step: a second-order step without the previous data prediction");
  const uint64_t bytes = count * 4;
  require_buffer("dpm_solver_step", "x", bytes, x);
  require_buffer("dpm_solver_step", "conditional prediction", bytes, v_cond);
  if (v_uncond) require_buffer("dpm_solver_step", "unconditional prediction", bytes, *v_uncond);
  if (c.second_order()) require_buffer("dpm_solver_step", "previous data prediction", bytes, *x0_prev);
  require_buffer("dpm_solver_step", "output", bytes, out);
  require_buffer("dpm_solver_step", "data prediction output", bytes, x0_out);
  shader::DpmSolverStepParams pc{0,
                                 (v_uncond ? NN_DPM_FLAG_CFG : 0u) | (c.second_order() ? NN_DPM_FLAG_SECOND_ORDER : 0u),
                                 cfg_scale,
                                 c.alpha_t,
                                 c.sigma_t,
                                 c.c_x,
                                 c.c_0,
                                 c.c_1,
                                 0};
  // A latent over one binding: windows of elements, the same range of every operand.
  const uint64_t fit = window_elements(ctx_, max_binding_bytes_);
  for (uint64_t first = 0; first < count; first += fit) {
    const uint64_t n = std::min(fit, count - first);
    const ElementWindow xw = element_window(ctx_, x, first, n);
    auto window = [&](const gpu::Buffer* b) { return b ? element_window(ctx_, *b, first, n).binding : gpu::null_binding(); };
    pc.count = static_cast<uint32_t>(n);
    pc.offset = xw.offset;
    cmd.dispatch(program_, gpu::Threads{n}, pc,
                 {xw.binding, window(&v_cond), window(v_uncond), window(c.second_order() ? x0_prev : nullptr),
                  window(&out), window(&x0_out)});
  }
}

}  // namespace icube::kernels::nn
