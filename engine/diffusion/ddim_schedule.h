// The DDIM sampler's schedule (the step itself: kernels/nn/ddim_step.h), as InfiniCube samples Stage 1
// (conventions §9.1; the official copy of diffusers' DDIMScheduler in
// schedulers/scheduling_ddim.py):
//   - T = 1000 training steps, linear betas 1e-4 .. 0.02 as torch.linspace
//     makes them in float32, alphas_cumprod = cumprod(1 - beta);
//   - "leading" timesteps: (0, 1, ..., steps - 1) * (T / steps), reversed,
//     plus steps_offset (0): 990, 980, ..., 0 for 100 steps;
//   - set_alpha_to_one: the step to t_prev < 0 uses alpha_prev = 1;
//   - v-prediction: x0 = sqrt(a_t) x - sqrt(1 - a_t) v,
//     eps = sqrt(a_t) v + sqrt(1 - a_t) x;
//   - sigma = eta * sqrt((1 - a_prev) / (1 - a_t) * (1 - a_t / a_prev)),
//     x_prev = sqrt(a_prev) x0 + sqrt(1 - a_prev - sigma^2) eps + sigma z, the
//     square root's argument clamped at 0 (diffusers would give NaN there); no
//     x0 clipping.
// Schedule arithmetic is float32 as the reference does it (each coefficient
// one float operation after another, as torch evaluates 0-d float tensors).
// torch's own float32 linspace is not one formula: its CPU kernel fills pairs
// of 8-lane vectors from bases computed with a fused multiply-add and the tail
// with the fused scalar expression (AVX2 builds: Debian's and the common pip
// builds), so linear_betas() reproduces exactly that
// (bit-equal to python3-torch 1.13 here) and cumprod accumulates in double as
// torch's CPU cumprod does. tests/diffusion/test_ddim_schedule.cpp states how
// far the plain float64 schedule is from it.
#pragma once

#include "kernels/nn/ddim_step.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace icube::diffusion {

// Where the inference timesteps sit: "leading" as the official sampler (uniform in t), or uniform in
// log-SNR lambda = log(alpha / sigma) from t = train_steps - 1 to 0, rounded to distinct integer
// timesteps (DPM-Solver's recommended "logSNR" spacing: equal steps h for a higher-order solver).
enum class TimestepSpacing { kLeading, kLogSnr };

struct DdimOptions {
  int train_steps = 1000;
  float beta_start = 1e-4f;
  float beta_end = 0.02f;
  int steps = 100;          // inference steps, 1 .. train_steps
  float eta = 1.0f;         // 1: the official default (stochastic); 0: deterministic DDIM
  int steps_offset = 0;
  bool set_alpha_to_one = true;
  TimestepSpacing spacing = TimestepSpacing::kLeading;
};

// The coefficients of one step from timestep t to t_prev (< 0 at the last step).
struct DdimStep {
  int t = 0, t_prev = 0;
  float alpha = 0, alpha_prev = 0;  // alphas_cumprod at t and t_prev (1 past the end with set_alpha_to_one)
  float sqrt_alpha = 0, sqrt_beta = 0;  // sqrt(a_t), sqrt(1 - a_t): v -> x0, eps
  float sqrt_alpha_prev = 0;           // times x0
  float direction = 0;                 // sqrt(max(0, 1 - a_prev - sigma^2)): times eps
  float sigma = 0;                     // times the step's noise z
  // What the step kernel and its CPU reference take (kernels/nn/ddim_step.h).
  kernels::nn::DdimStepCoefficients coefficients() const { return {sqrt_alpha, sqrt_beta, sqrt_alpha_prev, direction, sigma}; }
};

// torch.linspace(start, end, n, dtype=float32) as its CPU kernel computes it.
std::vector<float> linear_betas(int n, float start, float end);
// cumprod(1 - beta) in float32 output, double accumulation (torch's CPU cumprod).
std::vector<float> alphas_cumprod(const std::vector<float>& betas);

class DdimSchedule {
 public:
  // std::invalid_argument on steps outside 1 .. train_steps, a negative or non-finite eta, or betas
  // outside (0, 1).
  explicit DdimSchedule(const DdimOptions& options);
  const DdimOptions& options() const { return options_; }
  const std::vector<float>& alphas_cumprod() const { return alphas_cumprod_; }
  const std::vector<int>& timesteps() const { return timesteps_; }
  size_t size() const { return timesteps_.size(); }
  DdimStep step(size_t i) const;  // i-th step (timesteps()[i] -> the next; the last to alpha_prev)
  // sqrt(a_t), sqrt(1 - a_t) at timestep t: q(x_t | x0) = sqrt(a_t) x0 + sqrt(1 - a_t) eps (outpainting's
  // known latents are noised to the current level with these).
  void noise_level(int t, float* sqrt_alpha, float* sqrt_beta) const;

 private:
  DdimOptions options_;
  std::vector<float> alphas_cumprod_;
  std::vector<int> timesteps_;
};

}  // namespace icube::diffusion
