// The structure VAE decoder on the GPU (engine/nn/vae_gpu.h): the official
// vae_small decode (same voxel set at every level, logits within 1e-4 of their
// std), a random-weight model of the released structure against the CPU
// reference (every level's grid in the same brick order and its logits), and
// an all-empty decision. Runs under the validation layer.
#include "nn/scoped_kernel_family.h"
#include "gpu_test_context.h"
#include "half_values.h"
#include "kernels/nn/conv3d.h"
#include "kernels/nn/float16.h"
#include "nn/random_weights.h"
#include "nn/safetensors.h"
#include "nn/vae_gpu.h"
#include "nn/vae_reference.h"
#include "nn/vae_weights.h"
#include "vae_case_check.h"

#include <doctest/doctest.h>

#include <optional>
#include <random>

using namespace icube;

namespace {

// The tiny VAE; `order` as StructPredictionNet's (g: GroupNorm, c: conv, s: SiLU, r: ReLU).
nn::VaeConfig tiny_config(const std::string& order = "gcs") {
  return nn::parse_vae_config(R"({"cut_ratio": 8, "with_semantic_branch": true, "in_channels": 8, "num_blocks": 3,
    "f_maps": 8, "neck_dense_type": "HAND_CRAFTED", "neck_bound": [4, 4, 3], "num_res_blocks": 1, "use_residual": true,
    "order": ")" + order + R"(", "is_add_dec": true, "pooling_level": [2]})",
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

// The official vae_small decode through VaeGpu, every level within 1e-4 of std; `family` as in
// test_unet_gpu.cpp (nullptr: the device's own kernels).
static void check_vae_small(const char* family) {
  const std::string dir = test::test_data_dir();
  if (dir.empty()) return;
  std::optional<test::ScopedKernelFamily> scoped;
  if (family) scoped.emplace(family);
  const std::string m = dir + "/models/vae_small/";
  const nn::VaeConfig cfg = nn::load_vae_config(m + "config.json");
  const nn::SafetensorsFile file(m + "vae_weights.safetensors");
  nn::VaeGpu vae(test::gpu_context(), cfg, nn::load_vae_weights_cpu(file, cfg, nn::VaePart::Decoder));
  const nn::VaeDecoded d = vae.decode(test::vae_small_latent(m));
  const test::VaeCaseResult r = test::check_vae_small_decode(m, d);
  MESSAGE("vae_small decode (GPU, " << std::string(family ? family : "the device's") << " kernels): " << r.voxels
                                    << " voxels; structure logits max |d| / std " << r.worst_struct << ", semantic "
                                    << r.semantic << " (bound 1e-4); activations " << vae.last_activation_bytes() / 1024
                                    << " KiB");
}

TEST_CASE("vae gpu: vae_small decodes as the official StructPredictionNet, every level") { check_vae_small(nullptr); }

TEST_CASE("vae gpu: vae_small through the GPUs' kernel family (the tiled sparse conv) on the test device") {
  check_vae_small("gpu");
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

TEST_CASE("vae gpu: fp16 weight storage (exact on fp16-rounded weights; its error against fp32)") {
  const nn::VaeConfig cfg = tiny_config();
  const std::map<std::string, nn::CpuTensor> w = nn::random_weights(nn::vae_param_specs(cfg, nn::VaePart::Decoder), 5);
  std::map<std::string, nn::CpuTensor> rounded = w;  // the weights the kernels read: conv weights rounded to fp16
  for (auto& [name, t] : rounded)
    if (t.rank() >= 2)
      for (float& v : t.data) v = test::round_to_half(v);
  const nn::VaeReference ref16(cfg, rounded), ref32(cfg, w);
  nn::VaeGpu gpu(test::gpu_context(), cfg, w, nn::VaeGpu::Precision::F16Weights);
  nn::VaeGpu gpu32(test::gpu_context(), cfg, w);
  CHECK(gpu.weight_bytes() < gpu32.weight_bytes());
  // With cooperative matrices the sparse convolutions round their activations to fp16 too: only fp16's bound.
  const bool f16_operands = kernels::nn::conv3d_path_rounds_activations(
      kernels::nn::default_conv3d_path(test::gpu_context().info(), true));
  const nn::SparseTensor latent = random_latent(cfg, 1);
  const nn::VaeDecoded got = gpu.decode(latent), want = ref16.decode(latent), fp32 = ref32.decode(latent);
  REQUIRE(got.levels.size() == want.levels.size());
  for (size_t d = 0; d < want.levels.size(); ++d) {
    CAPTURE(d);
    CHECK(got.levels[d].grid.ijk == want.levels[d].grid.ijk);
    if (got.levels[d].logits.size() == want.levels[d].logits.size() && !want.levels[d].logits.empty())
      CHECK(nn::cpu::max_abs_over_std(got.levels[d].logits, want.levels[d].logits) <= (f16_operands ? 1e-2 : 1e-4));
  }
  REQUIRE(got.semantic.grid.ijk == want.semantic.grid.ijk);
  CHECK(nn::cpu::max_abs_over_std(got.semantic.data, want.semantic.data) <= (f16_operands ? 1e-2 : 1e-4));
  // Against the fp32 model: the rounding's own error (the same voxels here; a voxel near a structure
  // threshold may flip in general).
  if (got.semantic.grid.ijk == fp32.semantic.grid.ijk) {
    const double vs_fp32 = nn::cpu::max_abs_over_std(got.semantic.data, fp32.semantic.data);
    MESSAGE("tiny VAE, fp16 weights: semantic logits vs the fp32 reference " << vs_fp32 << " of std; weights "
                                                                             << gpu.weight_bytes() << " B against "
                                                                             << gpu32.weight_bytes() << " B");
    CHECK(vs_fp32 <= 1e-2);
    CHECK(vs_fp32 > 1e-7);  // the weights really are rounded
  }
}

TEST_CASE("vae gpu: fp16 precision (fp16 weights and fp16 GroupNorm outputs into the convolutions) against fp32") {
  // "gsc": a GroupNorm whose output goes to a SiLU first keeps it fp32 (only convolutions read fp16).
  for (const std::string order : {"gcs", "gsc"}) {
    CAPTURE(order);
    const nn::VaeConfig cfg = tiny_config(order);
    const std::map<std::string, nn::CpuTensor> w = nn::random_weights(nn::vae_param_specs(cfg, nn::VaePart::Decoder), 5);
    const nn::VaeReference ref32(cfg, w);
    gpu::Context& ctx = test::gpu_context();
    nn::VaeGpu f16(ctx, cfg, w, nn::VaeGpu::Precision::F16), f16_weights(ctx, cfg, w, nn::VaeGpu::Precision::F16Weights);
    const nn::SparseTensor latent = random_latent(cfg, 1);
    const nn::VaeDecoded got = f16.decode(latent), got_w = f16_weights.decode(latent), fp32 = ref32.decode(latent);
    REQUIRE(got.semantic.grid.ijk == fp32.semantic.grid.ijk);  // no voxel of this case sits at a structure threshold
    const double vs_fp32 = nn::cpu::max_abs_over_std(got.semantic.data, fp32.semantic.data);
    MESSAGE("tiny VAE, fp16: semantic logits vs the fp32 reference " << vs_fp32 << " of std");
    CHECK(vs_fp32 <= 1e-2);
    REQUIRE(got_w.semantic.grid.ijk == got.semantic.grid.ijk);
    const double operands = nn::cpu::max_abs_over_std(got.semantic.data, got_w.semantic.data);
    // The tensor cores round their operands anyway; with "gsc" no GroupNorm output is an operand (all fp32).
    if (order == "gsc" ||
        kernels::nn::conv3d_path_rounds_activations(kernels::nn::default_conv3d_path(ctx.info(), true)))
      CHECK(operands == 0.0);
    else
      CHECK(operands > 1e-7);
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

TEST_CASE("vae gpu: encode agrees with the CPU reference (max pooling, dense neck, moments)") {
  const nn::VaeConfig cfg = nn::parse_vae_config(R"({"vae_kwargs": {"cut_ratio": 8, "with_semantic_branch": true,
    "in_channels": 8, "num_blocks": 3, "f_maps": 8, "neck_dense_type": "HAND_CRAFTED", "neck_bound": [4, 4, 3],
    "num_res_blocks": 1, "use_residual": true, "order": "gcs", "is_add_dec": true, "pooling_level": [2]},
    "encoder_kwargs": {"dim_semantic": 6}})",
                                                 "tiny_vae.json");
  const std::map<std::string, nn::CpuTensor> w = nn::random_weights(nn::vae_param_specs(cfg, nn::VaePart::All), 11);
  const nn::VaeReference ref(cfg, w);
  nn::VaeGpu gpu(test::gpu_context(), cfg, w);
  // A ground slab, a box and scattered voxels at 0.2 m, some outside the neck's reach.
  nn::SparseGrid fine;
  fine.voxel_size = {0.2, 0.2, 0.2};
  fine.origin = {0.1, 0.1, 0.1};
  std::vector<int32_t> classes;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int32_t> cls(0, 22);
  for (int32_t i = -18; i < 18; ++i)
    for (int32_t j = -16; j < 17; ++j) {
      fine.ijk.push_back({i, j, -4});
      classes.push_back(cls(rng));
      if (i >= 2 && i < 6 && j >= -3 && j < 3)
        for (int32_t k = -3; k < 2; ++k) fine.ijk.push_back({i, j, k}), classes.push_back(1);
    }
  const nn::SparseTensor want = ref.encode(fine, classes), got = gpu.encode(fine, classes);
  REQUIRE(got.grid.ijk == want.grid.ijk);
  CHECK(got.channels == want.channels);
  const double e = nn::cpu::max_abs_over_std(got.data, want.data);
  INFO("mu: max |d| / std = " << e);
  CHECK(e <= 1e-4);
  // Decoding the GPU's latent on the GPU gives the reference's levels.
  const nn::VaeDecoded a = gpu.decode(got), b = ref.decode(want);
  for (size_t d = 0; d < a.levels.size(); ++d) CHECK(a.levels[d].grid.ijk == b.levels[d].grid.ijk);
  CHECK_THROWS_WITH_AS(gpu.encode(fine, std::vector<int32_t>(classes.size(), 23)), doctest::Contains("class 23 is outside"),
                       std::invalid_argument);
}
