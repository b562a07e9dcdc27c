// Counter-based Gaussian noise; see counter_noise.h.
#include "diffusion/counter_noise.h"

#include <Random123/philox.h>

#include <cmath>

namespace icube::diffusion {

std::array<uint32_t, 4> philox4x32_10(std::array<uint32_t, 4> c, std::array<uint32_t, 2> k) {
  const r123::Philox4x32_R<10> philox;
  const r123::Philox4x32_R<10>::ctr_type out = philox({{c[0], c[1], c[2], c[3]}}, {{k[0], k[1]}});
  return {out[0], out[1], out[2], out[3]};
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
