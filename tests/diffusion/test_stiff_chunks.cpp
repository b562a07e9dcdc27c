// Stage 1's stiff chunks end to end with the tiny random-weight models
// (presets infinicube-diffusion-tiny, infinicube-vae-tiny) on an 8^3 latent:
// a chunk whose condition volume is all zero (no positions, no map, no boxes),
// a chunk with no road (positions and one box heading only) and guidance 10 on
// both (2 steps each, eta 1 and 0), through the GPU UNet, the GPU DDIM step and the VAE decoder. The
// latent and the decoded logits stay finite, every class index is one of the
// VAE's classes, and where the conditional and unconditional inputs are the
// same (all zero) guidance changes nothing: cond + s (cond - uncond) = cond.
#include <doctest/doctest.h>

#include "diffusion/chunk_sampler.h"
#include "diffusion/unet_denoiser.h"
#include "gpu_test_context.h"
#include "nn/random_weights.h"
#include "nn/unet_config.h"
#include "nn/unet_gpu.h"
#include "nn/unet_reference.h"
#include "nn/vae_config.h"
#include "nn/vae_gpu.h"

#include <cmath>

using namespace icube;

namespace {

constexpr int kN = 8;

nn::CpuTensor zero_conditions() { return nn::CpuTensor({8, kN, kN, kN}); }

// Raw ijk positions and a parked box's heading; the map channels (road edge, line, surface) stay zero.
nn::CpuTensor no_road_conditions() {
  nn::CpuTensor c({8, kN, kN, kN});
  const size_t s = static_cast<size_t>(kN) * kN * kN;
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j)
      for (int k = 0; k < kN; ++k) {
        const size_t v = (static_cast<size_t>(i) * kN + static_cast<size_t>(j)) * kN + static_cast<size_t>(k);
        c.data[v] = static_cast<float>(i - kN / 2);
        c.data[s + v] = static_cast<float>(j - kN / 2);
        c.data[2 * s + v] = static_cast<float>(k - kN / 2);
        const bool box = k == 2 && i >= 3 && i < 5 && j == 2;
        c.data[6 * s + v] = box ? -1.0f : 0.0f;
      }
  return c;
}

struct Models {
  gpu::Context& ctx;
  nn::UNetConfig ucfg = nn::load_unet_config("infinicube-diffusion-tiny");
  nn::VaeConfig vcfg = nn::load_vae_config("infinicube-vae-tiny");
  nn::UNetGpu net;
  nn::VaeGpu vae;
  explicit Models(gpu::Context& c)
      : ctx(c),
        net(c, ucfg, nn::random_weights(nn::UNetReference(ucfg).parameters(), 5)),
        vae(c, vcfg, nn::random_weights(nn::vae_param_specs(vcfg, nn::VaePart::Decoder), 6)) {}

  std::vector<float> sample(const nn::CpuTensor& cond, float cfg, int steps, float eta) {
    diffusion::UNetDenoiser d(net);
    diffusion::SamplerOptions o;
    o.ddim.steps = steps;
    o.ddim.eta = eta;
    o.cfg_scale = cfg;
    o.seed = 11;
    return diffusion::sample_chunk(d, 8, cond, nullptr, 2, o, &ctx).latent.data;
  }

  nn::VaeDecoded decode(const std::vector<float>& latent) {
    const nn::Ijk lo{-kN / 2, -kN / 2, -kN / 2};
    const nn::SparseGrid grid = nn::dense_box_grid(lo, {kN, kN, kN}, {0.8, 0.8, 0.4}, {0.4, 0.4, 0.2});
    return vae.decode(nn::cpu::from_dense(nn::CpuTensor({1, 8, kN, kN, kN}, latent), lo, grid));
  }
};

void check_finite(const std::vector<float>& v, const char* what) {
  size_t bad = 0;
  for (const float x : v) bad += !std::isfinite(x);
  INFO(what);
  CHECK(bad == 0);
}

void check_decoded(const nn::VaeDecoded& d, int classes) {
  CHECK(d.semantic.channels == classes);
  size_t bad = 0;
  for (int64_t r = 0; r < d.semantic.rows(); ++r) {
    const float* l = d.semantic.row(r);
    for (int c = 0; c < d.semantic.channels; ++c) bad += !std::isfinite(l[c]);
  }
  CHECK(bad == 0);
}

}  // namespace

TEST_CASE("stiff chunks: all-zero conditions and no road, guidance 10, through the tiny UNet and VAE" * doctest::test_suite("slow-gpu")) {
  gpu::Context& ctx = test::gpu_context();
  Models m(ctx);

  SUBCASE("all-zero conditions: finite, and guidance 10 equals one pass (cond == uncond)") {
    const std::vector<float> one = m.sample(zero_conditions(), 1.0f, 2, 1.0f);
    const std::vector<float> ten = m.sample(zero_conditions(), 10.0f, 2, 1.0f);
    check_finite(one, "cfg 1");
    check_finite(ten, "cfg 10");
    double worst = 0, scale = 0;
    for (size_t i = 0; i < one.size(); ++i) {
      worst = std::max(worst, std::abs(double{one[i]} - double{ten[i]}));
      scale = std::max(scale, std::abs(double{one[i]}));
    }
    INFO("max |cfg10 - cfg1| = " << worst << " of max |x| = " << scale);
    CHECK(worst <= 1e-5 * scale);
    check_decoded(m.decode(ten), m.vcfg.num_semantic);
  }

  SUBCASE("no road: guidance 10 moves the latent but keeps it finite (eta 0)") {
    const std::vector<float> one = m.sample(no_road_conditions(), 1.0f, 2, 0.0f);
    const std::vector<float> ten = m.sample(no_road_conditions(), 10.0f, 2, 0.0f);
    check_finite(ten, "cfg 10");
    double diff = 0;
    for (size_t i = 0; i < one.size(); ++i) diff = std::max(diff, std::abs(double{one[i]} - double{ten[i]}));
    CHECK(diff > 0.0);  // the box makes cond != uncond, so the guidance acts
    check_decoded(m.decode(ten), m.vcfg.num_semantic);
  }
}
