// Counter-based noise (engine/diffusion/counter_noise.h): Philox4x32-10 on
// Random123's known-answer vectors (tests/kat_vectors); normals that depend
// only on (seed, chunk, step, purpose, element) — any split of the range, any
// order of chunks gives the same numbers, different streams differ; the
// moments of a million draws.
#include <doctest/doctest.h>

#include "diffusion/counter_noise.h"

#include <cmath>
#include <vector>

using namespace icube::diffusion;

TEST_CASE("noise: Philox4x32-10 matches Random123's known-answer vectors") {
  CHECK(philox4x32_10({0, 0, 0, 0}, {0, 0}) == std::array<uint32_t, 4>{0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u});
  CHECK(philox4x32_10({0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu}, {0xffffffffu, 0xffffffffu}) ==
        std::array<uint32_t, 4>{0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu});
  CHECK(philox4x32_10({0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}, {0xa4093822u, 0x299f31d0u}) ==
        std::array<uint32_t, 4>{0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u});
}

TEST_CASE("noise: a pure function of (seed, chunk, step, purpose, element); any split gives the same numbers") {
  const NoiseStream s{12345678901234ull, 3, 990, NoisePurpose::StepNoise};
  std::vector<float> whole(1001);
  normal_noise(s, 0, whole.data(), whole.size());
  // Pieces at odd offsets (not multiples of the 4-element quads), in reverse order.
  std::vector<float> pieces(1001);
  for (const auto& [a, b] : std::vector<std::pair<size_t, size_t>>{{997, 1001}, {513, 997}, {5, 513}, {0, 5}})
    normal_noise(s, a, pieces.data() + a, b - a);
  CHECK(pieces == whole);
  std::vector<float> again(1001);
  normal_noise(s, 0, again.data(), again.size());
  CHECK(again == whole);
  // Every field of the stream changes the numbers.
  for (NoiseStream other : {NoiseStream{s.seed + 1, 3, 990, NoisePurpose::StepNoise}, NoiseStream{s.seed, 4, 990, NoisePurpose::StepNoise},
                            NoiseStream{s.seed, 3, 980, NoisePurpose::StepNoise}, NoiseStream{s.seed, 3, 990, NoisePurpose::KnownLatent}}) {
    std::vector<float> o(1001);
    normal_noise(other, 0, o.data(), o.size());
    size_t same = 0;
    for (size_t i = 0; i < o.size(); ++i) same += o[i] == whole[i];
    CHECK(same < 5);
  }
  // Elements beyond 2^32 (the quad's high bits reach the counter).
  float far[4], near[4];
  normal_noise(s, (uint64_t{1} << 34), far, 4);
  normal_noise(s, 0, near, 4);
  CHECK(far[0] != near[0]);
}

TEST_CASE("noise: standard normal moments over a million draws, all finite") {
  std::vector<float> z(1 << 20);
  normal_noise({7, 0, 0, NoisePurpose::InitialLatent}, 0, z.data(), z.size());
  double m1 = 0, m2 = 0, m4 = 0;
  float lo = 0, hi = 0;
  for (const float v : z) {
    REQUIRE(std::isfinite(v));
    const double d = v;
    m1 += d;
    m2 += d * d;
    m4 += d * d * d * d;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  const double n = static_cast<double>(z.size());
  CHECK(std::abs(m1 / n) < 5e-3);          // 5 standard errors
  CHECK(std::abs(m2 / n - 1.0) < 7e-3);
  CHECK(std::abs(m4 / n - 3.0) < 0.05);
  CHECK(lo < -4.0f);  // tails reached (a million draws: |z| > 4 about 60 times)
  CHECK(hi > 4.0f);
  CHECK(lo > -7.0f);  // u never 0: the largest |z| is sqrt(-2 ln 2^-33) = 6.75
}
