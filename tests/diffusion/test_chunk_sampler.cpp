// One chunk's sampler (engine/diffusion/chunk_sampler.h) with analytic
// denoisers on small grids: an oracle that always predicts a fixed x0 brings
// the latent to exactly that x0 (eta 0 and 1, 1 to 1000 steps: the schedule's
// ends); guidance runs both inputs in one batch, zeroes the map and box
// channels of the second and combines as cond + s (cond - uncond); the same
// seed and chunk give the same latent on the CPU and GPU step and in any
// order, another chunk another latent; outpainting feeds the known cells
// noised to the current level with the counter noise and ends with them exact;
// with the GPU UNet the latent stays on the device (per step only the timestep
// embedding and the noise a step needs cross to it, nothing comes back).
#include <doctest/doctest.h>

#include "diffusion/chunk_sampler.h"
#include "diffusion/counter_noise.h"
#include "diffusion/unet_denoiser.h"
#include "gpu/buffer.h"
#include "gpu_test_context.h"
#include "nn/random_weights.h"
#include "nn/unet_config.h"
#include "nn/unet_gpu.h"

#include <cmath>
#include <random>

using namespace icube;
using namespace icube::diffusion;

namespace {

constexpr int64_t kC = 2, kX = 4, kY = 5, kZ = 3, kS = kX * kY * kZ;

nn::CpuTensor random_cond(uint32_t seed) {
  nn::CpuTensor c({8, kX, kY, kZ});
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (float& v : c.data) v = u(rng);
  return c;
}

// Predicts v so that x0 = target: v = (sqrt(a) x - target) / sqrt(1 - a). Records its inputs.
struct Oracle : Denoiser {
  std::vector<float> target;
  std::vector<float> alphas;
  std::vector<nn::CpuTensor> inputs;
  std::vector<int> ts;
  nn::CpuTensor predict(const nn::CpuTensor& x_in, int t) override {
    inputs.push_back(x_in);
    ts.push_back(t);
    const int64_t B = x_in.shape[0];
    nn::CpuTensor v({B, kC, kX, kY, kZ});
    const double a = alphas[static_cast<size_t>(t)];
    for (int64_t b = 0; b < B; ++b)
      for (int64_t i = 0; i < kC * kS; ++i) {
        const double x = x_in.data[static_cast<size_t>(b * (kC + 8) * kS + i)];
        v.data[static_cast<size_t>(b * kC * kS + i)] =
            static_cast<float>((std::sqrt(a) * x - double{target[static_cast<size_t>(i)]}) / std::sqrt(1.0 - a));
      }
    return v;
  }
};

Oracle make_oracle(uint32_t seed) {
  Oracle o;
  o.target.resize(kC * kS);
  std::mt19937 rng(seed);
  std::normal_distribution<float> nd(0.f, 1.f);
  for (float& v : o.target) v = nd(rng);
  o.alphas = DdimSchedule({}).alphas_cumprod();
  return o;
}

double max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(double{a[i]} - double{b[i]}));
  return m;
}

}  // namespace

TEST_CASE("chunk sampler: a denoiser that knows x0 brings the latent to x0 (eta 0 and 1, 1 to 1000 steps)") {
  const nn::CpuTensor cond = random_cond(1);
  for (const float eta : {0.0f, 1.0f})
    for (const int steps : {1, 10, 100, 1000}) {
      CAPTURE(eta);
      CAPTURE(steps);
      Oracle o = make_oracle(2);
      SamplerOptions opt;
      opt.ddim.eta = eta;
      opt.ddim.steps = steps;
      const ChunkSample s = sample_chunk(o, kC, cond, nullptr, 0, opt);
      CHECK(s.latent.shape == std::vector<int64_t>{1, kC, kX, kY, kZ});
      CHECK(o.ts.front() == (steps == 1000 ? 999 : (steps - 1) * (1000 / steps)));
      CHECK(o.ts.back() == 0);
      CHECK(s.steps.size() == static_cast<size_t>(steps));
      // The last step goes to alpha_prev = 1: x = x0 of the last prediction (fp32 rounding of v at t = 0).
      CHECK(max_abs_diff(s.latent.data, o.target) < 2e-4);
      // Inputs: the latent, then the condition volume, one batch element without guidance.
      CHECK(o.inputs.front().shape == std::vector<int64_t>{1, kC + 8, kX, kY, kZ});
      CHECK(std::equal(cond.data.begin(), cond.data.end(), o.inputs.front().data.begin() + kC * kS));
    }
}

TEST_CASE("chunk sampler: guidance batches the unconditional input (map and boxes zeroed) and combines cond + s (cond - uncond)") {
  const nn::CpuTensor cond = random_cond(3);
  // A denoiser whose prediction depends on the map channel, so cond and uncond differ.
  struct MapDependent : Denoiser {
    std::vector<int64_t> batches;
    nn::CpuTensor predict(const nn::CpuTensor& x_in, int) override {
      const int64_t B = x_in.shape[0];
      batches.push_back(B);
      nn::CpuTensor v({B, kC, kX, kY, kZ});
      for (int64_t b = 0; b < B; ++b)
        for (int64_t i = 0; i < kC * kS; ++i) {
          const size_t base = static_cast<size_t>(b * (kC + 8) * kS);
          v.data[static_cast<size_t>(b * kC * kS + i)] =
              0.5f * x_in.data[base + static_cast<size_t>(i)] + x_in.data[base + static_cast<size_t>((kC + 3) * kS + i % kS)] +
              0.1f * x_in.data[base + static_cast<size_t>(kC * kS + i % kS)];  // + position channel 0
        }
      return v;
    }
  };
  // The same combination written out by hand: one pass of cond + 2 (cond - uncond).
  struct Combined : Denoiser {
    MapDependent inner;
    nn::CpuTensor predict(const nn::CpuTensor& x_in, int t) override {
      nn::CpuTensor two({2, kC + 8, kX, kY, kZ});
      std::copy(x_in.data.begin(), x_in.data.end(), two.data.begin());
      std::copy(x_in.data.begin(), x_in.data.end(), two.data.begin() + static_cast<int64_t>(x_in.data.size()));
      std::fill_n(two.data.begin() + static_cast<int64_t>(x_in.data.size()) + (kC + 3) * kS, 5 * kS, 0.0f);
      const nn::CpuTensor v = inner.predict(two, t);
      nn::CpuTensor out({1, kC, kX, kY, kZ});
      nn::cpu::cfg_combine(v.data.data(), v.data.data() + kC * kS, 2.0f, out.data.data(), kC * kS);
      return out;
    }
  };
  SamplerOptions opt;
  opt.ddim.steps = 5;
  opt.cfg_scale = 2.0f;
  MapDependent d;
  const ChunkSample guided = sample_chunk(d, kC, cond, nullptr, 7, opt);
  CHECK(d.batches == std::vector<int64_t>(5, 2));
  Combined by_hand;
  opt.cfg_scale = 1.0f;  // one pass through the hand-written combination
  const ChunkSample want = sample_chunk(by_hand, kC, cond, nullptr, 7, opt);
  CHECK(guided.latent.data == want.latent.data);
  MapDependent single;
  sample_chunk(single, kC, cond, nullptr, 7, opt);
  CHECK(single.batches == std::vector<int64_t>(5, 1));  // s = 1: one pass
}

TEST_CASE("chunk sampler: the same seed and chunk give the same latent on the CPU and the GPU step, in any order") {
  const nn::CpuTensor cond = random_cond(4);
  SamplerOptions opt;
  opt.ddim.steps = 20;
  opt.cfg_scale = 3.0f;
  opt.seed = 99;
  Oracle a = make_oracle(5), b = make_oracle(5), c = make_oracle(5), d = make_oracle(5);
  const ChunkSample s2 = sample_chunk(a, kC, cond, nullptr, 2, opt);
  const ChunkSample s1 = sample_chunk(b, kC, cond, nullptr, 1, opt);
  const ChunkSample s2_again = sample_chunk(c, kC, cond, nullptr, 2, opt, &test::gpu_context());
  CHECK(max_abs_diff(s2.latent.data, s2_again.latent.data) < 1e-5);
  // The initial latents of chunks 1 and 2 differ (the oracle's first input).
  CHECK(a.inputs.front().data != b.inputs.front().data);
  CHECK(s1.latent.data.size() == s2.latent.data.size());
  opt.seed = 100;
  sample_chunk(d, kC, cond, nullptr, 2, opt);
  CHECK(d.inputs.front().data != a.inputs.front().data);
}

TEST_CASE("chunk sampler: outpainting noises the known cells to each level and ends with them exact") {
  const nn::CpuTensor cond = random_cond(6);
  KnownLatents known;
  known.mask.resize(kS);
  known.values.resize(kC * kS);
  std::mt19937 rng(8);
  std::normal_distribution<float> nd(0.f, 1.f);
  for (uint32_t& m : known.mask) m = rng() % 2;
  for (float& v : known.values) v = nd(rng);
  SamplerOptions opt;
  opt.ddim.steps = 10;
  opt.seed = 5;
  Oracle o = make_oracle(9);
  const ChunkSample s = sample_chunk(o, kC, cond, &known, 3, opt);
  const DdimSchedule sched(opt.ddim);
  for (size_t i = 0; i < o.inputs.size(); ++i) {
    CAPTURE(i);
    float a = 0, b = 0;
    sched.noise_level(o.ts[i], &a, &b);
    std::vector<float> z(kC * kS);
    normal_noise({5, 3, static_cast<uint32_t>(o.ts[i]), NoisePurpose::KnownLatent}, 0, z.data(), z.size());
    for (int64_t e = 0; e < kC * kS; ++e)
      if (known.mask[static_cast<size_t>(e % kS)])
        CHECK(o.inputs[i].data[static_cast<size_t>(e)] == a * known.values[static_cast<size_t>(e)] + b * z[static_cast<size_t>(e)]);
  }
  size_t known_cells = 0;
  for (int64_t e = 0; e < kC * kS; ++e) {
    if (known.mask[static_cast<size_t>(e % kS)]) {
      ++known_cells;
      CHECK(s.latent.data[static_cast<size_t>(e)] == known.values[static_cast<size_t>(e)]);
    } else {
      CHECK(std::abs(s.latent.data[static_cast<size_t>(e)] - o.target[static_cast<size_t>(e)]) < 2e-4f);
    }
  }
  CHECK(known_cells > 0);
  // The same on the GPU (step and overwrite kernels): the known cells exact, the rest as on the CPU.
  Oracle og = make_oracle(9);
  const ChunkSample g = sample_chunk(og, kC, cond, &known, 3, opt, &test::gpu_context());
  for (int64_t e = 0; e < kC * kS; ++e)
    if (known.mask[static_cast<size_t>(e % kS)]) CHECK(g.latent.data[static_cast<size_t>(e)] == known.values[static_cast<size_t>(e)]);
  CHECK(max_abs_diff(g.latent.data, s.latent.data) < 1e-5);
  // Wrong sizes: refused.
  KnownLatents bad = known;
  bad.values.pop_back();
  Oracle o2 = make_oracle(9);
  CHECK_THROWS_WITH_AS(sample_chunk(o2, kC, cond, &bad, 3, opt), doctest::Contains("known latents of"), std::invalid_argument);
}

TEST_CASE("chunk sampler: with the GPU UNet the latent stays on the device, per step only the noise and the timestep cross") {
  const nn::UNetConfig cfg = nn::load_unet_config("infinicube-diffusion-tiny");
  nn::UNetGpu net(test::gpu_context(), cfg, nn::random_weights(nn::UNetReference(cfg).parameters(), 5));
  UNetDenoiser denoiser(net);
  constexpr int64_t n = 8;  // an 8^3 latent of 8 channels
  nn::CpuTensor cond({8, n, n, n});
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (float& v : cond.data) v = u(rng);
  KnownLatents known;
  known.mask.assign(n * n * n, 0);
  known.values.assign(8 * n * n * n, 0.0f);
  for (size_t v = 0; v < known.mask.size(); v += 3) known.mask[v] = 1;
  for (float& v : known.values) v = u(rng);
  const uint64_t latent_bytes = 8 * n * n * n * 4;
  struct Case {
    float eta, cfg;
    bool outpaint;
  };
  for (const Case c : {Case{0.0f, 2.0f, false}, Case{1.0f, 2.0f, false}, Case{0.0f, 1.0f, true}}) {
    CAPTURE(c.eta);
    CAPTURE(c.cfg);
    CAPTURE(c.outpaint);
    SamplerOptions o;
    o.ddim.steps = 3;
    o.ddim.eta = c.eta;
    o.cfg_scale = c.cfg;
    o.seed = 21;
    const ChunkSample dev = sample_chunk(denoiser, 8, cond, c.outpaint ? &known : nullptr, 4, o, &test::gpu_context());
    const uint64_t timestep_bytes = (c.cfg != 1.0f ? 2 : 1) * static_cast<uint64_t>(cfg.model_channels) * 4;
    const DdimSchedule sched(o.ddim);
    REQUIRE(dev.steps.size() == sched.size());
    for (size_t i = 0; i < sched.size(); ++i) {
      CAPTURE(i);
      const bool step_noise = sched.step(i).sigma != 0.0f;
      if (i == 0) CHECK(step_noise == (c.eta != 0.0f));
      CHECK(dev.steps[i].host_bytes == timestep_bytes + (step_noise ? latent_bytes : 0) + (c.outpaint ? latent_bytes : 0));
    }
    // The same chunk with the latent on the host (the UNet's host form, the CPU step): equal to rounding.
    const ChunkSample host = sample_chunk(denoiser, 8, cond, c.outpaint ? &known : nullptr, 4, o);
    CHECK(max_abs_diff(dev.latent.data, host.latent.data) < 1e-4);
  }
}
