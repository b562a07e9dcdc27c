// DPM-Solver++ (2M) coefficients; see dpm_solver.h.
#include "diffusion/dpm_solver.h"

#include <cmath>

namespace icube::diffusion {

namespace {

struct Level {
  double alpha, sigma, lambda;
};

Level level(float a) {
  const double alpha = std::sqrt(static_cast<double>(a)), sigma = std::sqrt(1.0 - static_cast<double>(a));
  return {alpha, sigma, std::log(alpha) - std::log(sigma)};
}

}  // namespace

kernels::nn::DpmSolverStepCoefficients dpm_solver_coefficients(const DdimSchedule& schedule, size_t i) {
  const DdimStep st = schedule.step(i);
  const Level t = level(st.alpha);
  kernels::nn::DpmSolverStepCoefficients c;
  c.alpha_t = static_cast<float>(t.alpha);
  c.sigma_t = static_cast<float>(t.sigma);
  if (st.alpha_prev >= 1.0f) {  // to sigma = 0: the data prediction itself
    c.c_x = 0.0f;
    c.c_0 = 1.0f;
    return c;
  }
  const Level s = level(st.alpha_prev);
  const double h = s.lambda - t.lambda;
  const double gain = s.alpha * -std::expm1(-h);  // alpha_s (1 - e^-h)
  c.c_x = static_cast<float>(s.sigma / t.sigma);
  if (i == 0) {
    c.c_0 = static_cast<float>(gain);
    return c;
  }
  const Level prev = level(schedule.alphas_cumprod()[static_cast<size_t>(schedule.timesteps()[i - 1])]);
  const double r = (t.lambda - prev.lambda) / h;
  c.c_0 = static_cast<float>(gain * (1.0 + 0.5 / r));
  c.c_1 = static_cast<float>(-gain * 0.5 / r);
  return c;
}

}  // namespace icube::diffusion
