// The networks' agreement metric nn::cpu::max_abs_over_std (kernels/nn/cpu_tensor.h): max |got - ref| /
// std(ref), and no pass for a NaN or an unmatched infinity (std::max alone skips NaN, which let a GPU
// stage's NaN output pass as "0 of std").
#include <doctest/doctest.h>

#include "kernels/nn/cpu_tensor.h"

#include <cmath>
#include <limits>

using namespace icube;

TEST_CASE("agreement metric: max |got - ref| / std(ref), NaN and unmatched infinities never pass") {
  const std::vector<float> ref{1.0f, 3.0f, 1.0f, 3.0f};  // mean 2, population std 1
  CHECK(nn::cpu::max_abs_over_std(ref, ref) == 0.0);
  CHECK(nn::cpu::max_abs_over_std({1.0f, 3.5f, 1.0f, 3.0f}, ref) == doctest::Approx(0.5));
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  CHECK(std::isinf(nn::cpu::max_abs_over_std({nan, 3.0f, 1.0f, 3.0f}, ref)));
  CHECK(std::isinf(nn::cpu::max_abs_over_std({inf, 3.0f, 1.0f, 3.0f}, ref)));
  CHECK(std::isinf(nn::cpu::max_abs_over_std({nan, nan, nan, nan}, ref)));
  CHECK_FALSE(nn::cpu::max_abs_over_std({nan, 3.0f, 1.0f, 3.0f}, ref) <= 1e-4);
  // A reference with a NaN never passes.
  CHECK_FALSE(nn::cpu::max_abs_over_std({nan, 3.0f}, {nan, 3.0f}) <= 1e-4);
}
