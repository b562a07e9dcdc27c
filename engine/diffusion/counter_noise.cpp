// Counter-based Gaussian noise; see counter_noise.h.
#include "diffusion/counter_noise.h"

#include <cmath>

namespace icube::diffusion {

std::array<uint32_t, 4> philox4x32_10(std::array<uint32_t, 4> c, std::array<uint32_t, 2> k) {
  constexpr uint32_t kMul0 = 0xD2511F53u, kMul1 = 0xCD9E8D57u;   // Philox4x32 multipliers
  constexpr uint32_t kWeyl0 = 0x9E3779B9u, kWeyl1 = 0xBB67AE85u;  // key schedule (golden ratio, sqrt(3) - 1)
  for (int round = 0; round < 10; ++round) {
    const uint64_t p0 = uint64_t{kMul0} * c[0], p1 = uint64_t{kMul1} * c[2];
    c = {static_cast<uint32_t>(p1 >> 32) ^ c[1] ^ k[0], static_cast<uint32_t>(p1), static_cast<uint32_t>(p0 >> 32) ^ c[3] ^ k[1],
         static_cast<uint32_t>(p0)};
    k[0] += kWeyl0;
    k[1] += kWeyl1;
  }
  return c;
}

void normal_noise(const NoiseStream& s, uint64_t first, float* out, size_t n) {
  const std::array<uint32_t, 2> key{static_cast<uint32_t>(s.seed), static_cast<uint32_t>(s.seed >> 32)};
  constexpr double kTwoPi = 6.283185307179586476925;
  constexpr double kInv32 = 1.0 / 4294967296.0;
  for (uint64_t e = first / 4 * 4; e < first + n; e += 4) {
    // Counter: the element quad (low 32 bits), the step, the chunk, the purpose and the quad's high bits.
    const uint64_t quad = e / 4;
    const std::array<uint32_t, 4> r =
        philox4x32_10({static_cast<uint32_t>(quad), s.step, s.chunk, static_cast<uint32_t>(s.purpose) | static_cast<uint32_t>(quad >> 32) << 8},
                      key);
    double z[4];
    for (int pair = 0; pair < 2; ++pair) {
      const double u1 = (static_cast<double>(r[2 * pair]) + 0.5) * kInv32;
      const double u2 = (static_cast<double>(r[2 * pair + 1]) + 0.5) * kInv32;
      const double radius = std::sqrt(-2.0 * std::log(u1));
      z[2 * pair] = radius * std::cos(kTwoPi * u2);
      z[2 * pair + 1] = radius * std::sin(kTwoPi * u2);
    }
    for (uint64_t j = 0; j < 4; ++j)
      if (e + j >= first && e + j < first + n) out[e + j - first] = static_cast<float>(z[j]);
  }
}

}  // namespace icube::diffusion
