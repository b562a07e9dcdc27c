// Counter-based Gaussian noise for the sampler: element e of the stream
// (seed, chunk, step, purpose) is a pure function of those five numbers, so a
// world is the same on any device, thread count and chunk order, and one chunk
// can be regenerated alone. Philox4x32-10 (Salmon et al., "Parallel random
// numbers: as easy as 1, 2, 3", SC 2011; Random123's own implementation, Debian
// librandom123-dev) keyed by
// the 64-bit seed, counter (e / 4, step, chunk, purpose), gives 4 uint32; each
// pair (u1, u2), u = (x + 0.5) / 2^32, becomes two normals by Box-Muller in
// double, sqrt(-2 ln u1) * (cos, sin)(2 pi u2), rounded to float. Made on the
// host (a 64^3 x 8 latent's noise takes tens of milliseconds), so no device's
// transcendental functions enter the numbers.
// Tests: tests/diffusion/test_counter_noise.cpp.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace icube::diffusion {

enum class NoisePurpose : uint32_t {
  InitialLatent = 0,  // x_T
  StepNoise = 1,      // z of the DDIM step from timestep `step`
  KnownLatent = 2,    // outpainting: the fresh noise on the known latents at timestep `step`
};

struct NoiseStream {
  uint64_t seed = 0;
  uint32_t chunk = 0;  // the chunk's index in the plan
  uint32_t step = 0;   // the timestep (or 0 for the initial latent)
  NoisePurpose purpose = NoisePurpose::InitialLatent;
};

// Philox4x32-10 of (counter, key).
std::array<uint32_t, 4> philox4x32_10(std::array<uint32_t, 4> counter, std::array<uint32_t, 2> key);

// Standard normals for elements [first, first + n) of the stream.
void normal_noise(const NoiseStream& stream, uint64_t first, float* out, size_t n);

}  // namespace icube::diffusion
