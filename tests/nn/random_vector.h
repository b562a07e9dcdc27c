// Seeded normal samples for the nn kernel tests: n values of N(0, scale^2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

namespace icube::test {

inline std::vector<float> random_vector(size_t n, float scale, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> nd(0.0f, scale);
  std::vector<float> v(n);
  for (float& f : v) f = nd(rng);
  return v;
}

}  // namespace icube::test
