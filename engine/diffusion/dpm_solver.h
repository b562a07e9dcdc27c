// DPM-Solver++ (2M) on the diffusion schedule (Lu et al., "DPM-Solver++:
// Fast Solver for Guided Sampling of Diffusion Probabilistic Models", 2022; the
// data-prediction multistep solver as diffusers' DPMSolverMultistepScheduler
// runs it with algorithm_type "dpmsolver++", solver_order 2, solver_type
// "midpoint", lower_order_final). With alpha = sqrt(a_t), sigma = sqrt(1 - a_t),
// lambda = log(alpha / sigma), h = lambda_s - lambda_t for the step t -> s and
// the data predictions m0 (this step's) and m1 (the previous step's, at t'):
//   first order:  x_s = (sigma_s / sigma_t) x + alpha_s (1 - e^-h) m0  (= DDIM, eta 0)
//   second order: x_s = (sigma_s / sigma_t) x + alpha_s (1 - e^-h) (m0 + (m0 - m1) / (2 r)),
//                 r = (lambda_t - lambda_t') / h.
// The first step is first order (no m1); so is the last, to alpha = 1 (sigma_s = 0,
// h infinite: x_s = m0). The solver is deterministic (no step noise); guidance
// and outpainting act on the prediction and the latent exactly as for DDIM.
// Coefficients are computed in double from the schedule's float32 alphas, for
// any timesteps; the sampler runs it on log-SNR-uniform ones
// (TimestepSpacing::kLogSnr, schedule_options in chunk_sampler.h): on DDIM's
// leading spacing the steps in lambda are uneven (the last, t = 1000/n -> 0,
// is several times its predecessor), the multistep extrapolation overshoots,
// and below ~40 steps it was no better than DDIM (bench/README.md).
// The step kernel: kernels/nn/dpm_solver_step.h. Tests: tests/diffusion/test_dpm_solver.cpp.
#pragma once

#include "diffusion/ddim_schedule.h"
#include "kernels/nn/dpm_solver_step.h"

#include <cstddef>

namespace icube::diffusion {

// Step i of `schedule` (timesteps()[i] -> the next, the last to alpha_prev): second order when 0 < i < last.
kernels::nn::DpmSolverStepCoefficients dpm_solver_coefficients(const DdimSchedule& schedule, size_t i);

}  // namespace icube::diffusion
