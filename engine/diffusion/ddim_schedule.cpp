// DDIM schedule and step; see ddim_schedule.h.
#include "diffusion/ddim_schedule.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::diffusion {

std::vector<float> linear_betas(int n, float start, float end) {
  if (n < 1) throw std::invalid_argument("linear_betas: " + std::to_string(n) + " steps");
  std::vector<float> out(static_cast<size_t>(n));
  if (n == 1) {
    out[0] = start;
    return out;
  }
  // aten/src/ATen/native/cpu/RangeFactoriesKernel.cpp (linspace_kernel) through cpu_serial_kernel_vec:
  // step in float; the first half counts up from start, the second down from end. The vectorised loop
  // takes two 8-lane vectors at a time, each base + j * step (the product rounded, then the sum) with
  // its base from one fused multiply-add; the elements past the last whole pair of vectors take the
  // scalar expression, also fused (the kernel is compiled with FMA). One parallel chunk (n <= 32,768,
  // torch's grain size): larger n would split differently there.
  const float step = (end - start) / static_cast<float>(n - 1);
  const int64_t halfway = n / 2, lanes = 8;
  auto fused = [&](int64_t idx) {
    return idx < halfway ? std::fma(step, static_cast<float>(idx), start)
                         : std::fma(-step, static_cast<float>(n - idx - 1), end);
  };
  int64_t idx = 0;
  for (; idx + 2 * lanes <= n; idx += lanes) {
    const float b = fused(idx);
    for (int64_t j = 0; j < lanes; ++j) {
      const float offset = static_cast<float>(j) * step;
      out[static_cast<size_t>(idx + j)] = b + offset;
    }
    idx += lanes;
    const float b2 = fused(idx);
    for (int64_t j = 0; j < lanes; ++j) {
      const float offset = static_cast<float>(j) * step;
      out[static_cast<size_t>(idx + j)] = b2 + offset;
    }
  }
  for (; idx < n; ++idx) out[static_cast<size_t>(idx)] = fused(idx);
  return out;
}

std::vector<float> alphas_cumprod(const std::vector<float>& betas) {
  std::vector<float> out(betas.size());
  double acc = 1.0;
  for (size_t i = 0; i < betas.size(); ++i) {
    const float one_minus = 1.0f - betas[i];
    acc *= static_cast<double>(one_minus);
    out[i] = static_cast<float>(acc);
  }
  return out;
}

DdimSchedule::DdimSchedule(const DdimOptions& o) : options_(o) {
  if (o.train_steps < 1 || o.train_steps > 100000)
    throw std::invalid_argument("ddim: " + std::to_string(o.train_steps) + " training steps");
  if (o.steps < 1 || o.steps > o.train_steps)
    throw std::invalid_argument("ddim: --steps " + std::to_string(o.steps) + " is not in 1.." + std::to_string(o.train_steps));
  if (!std::isfinite(o.eta) || o.eta < 0.0f)
    throw std::invalid_argument("ddim: --eta " + std::to_string(o.eta) + " is not a finite number >= 0");
  if (!(o.beta_start > 0.0f && o.beta_end < 1.0f && o.beta_start <= o.beta_end))
    throw std::invalid_argument("ddim: betas " + std::to_string(o.beta_start) + " .. " + std::to_string(o.beta_end) +
                                " are not in (0, 1)");
  if (o.steps_offset < 0 || o.steps_offset >= o.train_steps)
    throw std::invalid_argument("ddim: steps_offset " + std::to_string(o.steps_offset));
  alphas_cumprod_ = diffusion::alphas_cumprod(linear_betas(o.train_steps, o.beta_start, o.beta_end));
  if (o.spacing == TimestepSpacing::kLogSnr) {
    // lambda(t) falls with t; targets uniform from lambda(T - 1) to lambda(0), each rounded to the nearest
    // timestep, then kept distinct (below the previous one, with room left for the rest).
    const int T = o.train_steps;
    auto lambda = [&](int t) {
      const double a = alphas_cumprod_[static_cast<size_t>(t)];
      return 0.5 * (std::log(a) - std::log1p(-a));
    };
    const double l_first = lambda(T - 1), l_last = lambda(0);
    for (int i = 0; i < o.steps; ++i) {
      const double target = o.steps == 1 ? l_first : l_first + (l_last - l_first) * i / (o.steps - 1);
      int lo = 0, hi = T - 1;  // the first t with lambda(t) <= target
      while (lo < hi) {
        const int mid = (lo + hi) / 2;
        if (lambda(mid) <= target) hi = mid;
        else lo = mid + 1;
      }
      int t = lo > 0 && std::abs(lambda(lo - 1) - target) < std::abs(lambda(lo) - target) ? lo - 1 : lo;
      if (!timesteps_.empty()) t = std::min(t, timesteps_.back() - 1);
      t = std::max(t, o.steps - 1 - i);
      timesteps_.push_back(t);
    }
    return;
  }
  const int ratio = o.train_steps / o.steps;
  for (int i = o.steps - 1; i >= 0; --i) timesteps_.push_back(std::min(i * ratio + o.steps_offset, o.train_steps - 1));
}

void DdimSchedule::noise_level(int t, float* sqrt_alpha, float* sqrt_beta) const {
  const float a = alphas_cumprod_.at(static_cast<size_t>(t));
  *sqrt_alpha = std::sqrt(a);
  *sqrt_beta = std::sqrt(1.0f - a);
}

DdimStep DdimSchedule::step(size_t i) const {
  DdimStep s;
  s.t = timesteps_.at(i);
  s.t_prev = options_.spacing == TimestepSpacing::kLeading ? s.t - options_.train_steps / options_.steps
                                                            : (i + 1 < timesteps_.size() ? timesteps_[i + 1] : -1);
  s.alpha = alphas_cumprod_[static_cast<size_t>(s.t)];
  s.alpha_prev = s.t_prev >= 0 ? alphas_cumprod_[static_cast<size_t>(s.t_prev)]
                               : (options_.set_alpha_to_one ? 1.0f : alphas_cumprod_[0]);
  const float beta = 1.0f - s.alpha, beta_prev = 1.0f - s.alpha_prev;
  s.sqrt_alpha = std::sqrt(s.alpha);
  s.sqrt_beta = std::sqrt(beta);
  s.sqrt_alpha_prev = std::sqrt(s.alpha_prev);
  const float variance = (beta_prev / beta) * (1.0f - s.alpha / s.alpha_prev);
  s.sigma = options_.eta * std::sqrt(std::max(variance, 0.0f));
  const float dir2 = 1.0f - s.alpha_prev - s.sigma * s.sigma;
  s.direction = std::sqrt(std::max(dir2, 0.0f));
  return s;
}

}  // namespace icube::diffusion
