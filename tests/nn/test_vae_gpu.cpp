// The structure VAE decoder on the GPU (engine/nn/vae_gpu.h): the official
// vae_small decode (same voxel set at every level, logits within 1e-4 of their
// std), a random-weight model of the released structure against the CPU
// reference (every level's grid in the same brick order and its logits), and
// an all-empty decision. Runs under the validation layer.
#include "gpu_test_context.h"
#include "nn/random_weights.h"
#include "nn/safetensors.h"
#include "nn/vae_gpu.h"
#include "nn/vae_reference.h"
#include "nn/vae_weights.h"
#include "vae_case_check.h"

#include <doctest/doctest.h>

#include <random>

using namespace icube;

namespace {

nn::VaeConfig tiny_config() {
  return nn::parse_vae_config(R"({"cut_ratio": 8, "with_semantic_branch": true, "in_channels": 8, "num_blocks": 3,
    "f_maps": 8, "neck_dense_type": "HAND_CRAFTED", "neck_bound": [4, 4, 3], "num_res_blocks": 1, "use_residual": true,
    "order": "gcs", "is_add_dec": true, "pooling_level": [2]})",
                              "tiny_vae.json");
}

nn::SparseTensor random_latent(const nn::VaeConfig& cfg, uint32_t seed) {
  nn::SparseTensor t;
  t.grid = nn::dense_box_grid({-4, -4, -3}, {8, 8, 6}, {0.8, 0.8, 0.4}, {0.4, 0.4, 0.2});
  t.channels = cfg.latent_channels();
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, 1.0f);
  t.data.resize(static_cast<size_t>(t.rows() * t.channels));
  for (float& v : t.data) v = n(rng);
  return t;
}

}  // namespace

TEST_CASE("vae gpu: vae_small decodes as the official StructPredictionNet, every level") {
  const std::string dir = test::test_data_dir();
  if (dir.empty()) return;
  const std::string m = dir + "/models/vae_small/";
  const nn::VaeConfig cfg = nn::load_vae_config(m + "config.json");
  const nn::SafetensorsFile file(m + "vae_weights.safetensors");
  nn::VaeGpu vae(test::gpu_context(), cfg, nn::load_vae_weights_cpu(file, cfg, nn::VaePart::Decoder));
  const nn::VaeDecoded d = vae.decode(test::vae_small_latent(m));
  const test::VaeCaseResult r = test::check_vae_small_decode(m, d);
  MESSAGE("vae_small decode (GPU): " << r.voxels << " voxels; structure logits max |d| / std " << r.worst_struct
                                     << ", semantic " << r.semantic << " (bound 1e-4); activations "
                                     << vae.last_activation_bytes() / 1024 << " KiB");
}

TEST_CASE("vae gpu: a random-weight model agrees with the CPU reference level by level") {
  const nn::VaeConfig cfg = tiny_config();
  const std::map<std::string, nn::CpuTensor> w = nn::random_weights(nn::vae_param_specs(cfg, nn::VaePart::Decoder), 5);
  const nn::VaeReference ref(cfg, w);
  nn::VaeGpu gpu(test::gpu_context(), cfg, w);
  for (const uint32_t seed : {1u, 2u}) {
    CAPTURE(seed);
    const nn::SparseTensor latent = random_latent(cfg, seed);
    const nn::VaeDecoded want = ref.decode(latent), got = gpu.decode(latent);
    REQUIRE(got.levels.size() == want.levels.size());
    for (size_t d = 0; d < want.levels.size(); ++d) {
      CAPTURE(d);
      CHECK(got.levels[d].grid.ijk == want.levels[d].grid.ijk);
      CHECK(got.levels[d].grid.voxel_size == want.levels[d].grid.voxel_size);
      if (got.levels[d].logits.size() == want.levels[d].logits.size() && !want.levels[d].logits.empty())
        CHECK(nn::cpu::max_abs_over_std(got.levels[d].logits, want.levels[d].logits) <= 1e-4);
    }
    CHECK(got.semantic.grid.ijk == want.semantic.grid.ijk);
    if (!want.semantic.data.empty()) CHECK(nn::cpu::max_abs_over_std(got.semantic.data, want.semantic.data) <= 1e-4);
    CHECK(got.warning == want.warning);
  }
}

TEST_CASE("vae gpu: an all-empty structure decision decodes to an empty chunk with a warning") {
  const nn::VaeConfig cfg = tiny_config();
  std::map<std::string, nn::CpuTensor> w = nn::random_weights(nn::vae_param_specs(cfg, nn::VaePart::Decoder), 3);
  w.at("unet.struct_convs.Struct-2.OutConv.bias").data = {-100.0f, 100.0f};  // the second level drops everything
  nn::VaeGpu vae(test::gpu_context(), cfg, w);
  const nn::VaeDecoded d = vae.decode(random_latent(cfg, 4));
  CHECK(d.warning.find("depth 1 kept no voxel") != std::string::npos);
  CHECK(d.levels[0].grid.size() == 0);
  CHECK(d.semantic.rows() == 0);
  CHECK(d.semantic.channels == 23);
}
