// The GSM's Depth-Anything-V2 feature stage, CPU reference (engine/nn/gsm/dav2_reference.h),
// against the official gsm_small case: every enc.dav2.* intermediate and the stage's output,
// and the configuration read from config.json.
#include "gsm_case.h"
#include "nn/gsm/dav2_reference.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_trace.h"
#include "nn/gsm/gsm_weights.h"

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

using namespace icube;

namespace {

nlohmann::json read_case_config(const std::string& dir) {
  std::ifstream f(dir + "config.json");
  REQUIRE_MESSAGE(f.good(), "cannot read " << dir << "config.json");
  return nlohmann::json::parse(f);
}

// [B, N, H, W, 3] -> [B * N, 3, H, W].
nn::CpuTensor views_channels_first(const nn::GsmInputs& in) {
  const int64_t V = in.batch * in.views, H = in.height, W = in.width;
  nn::CpuTensor x({V, 3, H, W});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t c = 0; c < 3; ++c)
      for (int64_t p = 0; p < H * W; ++p)
        x.data[static_cast<size_t>((v * 3 + c) * H * W + p)] = in.images.data[static_cast<size_t>((v * H * W + p) * 3 + c)];
  return x;
}

}  // namespace

TEST_CASE("gsm reference: Depth-Anything-V2 features match the official enc.dav2.* intermediates") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::Dav2Config cfg = nn::dav2_config_from_json(read_case_config(dir));
  const nn::GsmWeights weights = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  nn::GsmTrace trace;
  const nn::CpuTensor out = nn::dav2_features(cfg, weights, views_channels_first(in), &trace, in.batch);

  std::vector<std::string> names = {"enc.dav2.pixel_values", "enc.dav2.pos_embed_interp", "enc.dav2.embeddings"};
  for (int64_t i = 0; i < cfg.num_layers; ++i) names.push_back("enc.dav2.layer." + std::to_string(i));
  for (const char* stage : {"feature_maps", "reassemble", "neck_conv", "fusion"})
    for (size_t k = 0; k < cfg.out_indices.size(); ++k) names.push_back(std::string("enc.dav2.") + stage + "." + std::to_string(k));
  for (size_t j = 0; j + 1 < cfg.upsampler.size(); ++j) names.push_back("enc.dav2.upsampler." + std::to_string(j));
  names.push_back("enc.dav2.out");

  const test::GsmTensors ref(dir + "intermediates.safetensors");
  MESSAGE("Depth-Anything-V2 features (CPU reference) against gsm_small:");
  for (const std::string& name : names) {
    REQUIRE_MESSAGE(trace.tensors.count(name) == 1, "the stage did not record " << name);
    test::check_gsm_tensor(ref, name, trace.tensors.at(name));
  }
  CHECK(trace.tensors.size() == names.size());

  // The returned [V, C, h, w] map is the recorded [B, N, C, h, w] output.
  const nn::CpuTensor& recorded = trace.tensors.at("enc.dav2.out");
  CHECK(out.shape == std::vector<int64_t>{in.batch * in.views, cfg.upsampler.back().out_dim, recorded.dim(3), recorded.dim(4)});
  CHECK(out.data == recorded.data);
}

TEST_CASE("gsm reference: Depth-Anything-V2 configuration from config.json, missing keys named") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nlohmann::json config = read_case_config(dir);
  const nn::Dav2Config cfg = nn::dav2_config_from_json(config);
  CHECK(cfg.hidden_size == 64);
  CHECK(cfg.num_layers == 4);
  CHECK(cfg.num_heads == 4);
  CHECK(cfg.patch_size == 14);
  CHECK(cfg.mlp_hidden == 256);
  CHECK(cfg.position_grid == 37);
  CHECK(cfg.layer_norm_eps == doctest::Approx(1e-6));
  CHECK(cfg.out_indices == std::vector<int64_t>{1, 2, 3, 4});
  CHECK(cfg.neck_hidden_sizes == std::vector<int64_t>{16, 32, 64, 64});
  CHECK(cfg.reassemble_factors == std::vector<double>{4, 2, 1, 0.5});
  CHECK(cfg.fusion_hidden_size == 32);
  CHECK(cfg.input_height == 56);
  CHECK(cfg.input_width == 84);
  REQUIRE(cfg.upsampler.size() == 2);
  CHECK(cfg.upsampler[0].out_dim == 16);
  CHECK(cfg.upsampler[1].out_dim == 8);
  CHECK((cfg.upsampler[0].up && !cfg.upsampler[0].down && !cfg.upsampler[0].group_norm));

  auto without = [&](const nlohmann::json::json_pointer& key) {
    nlohmann::json c = config;
    c.at(key.parent_pointer()).erase(key.back());
    return c;
  };
  using P = nlohmann::json::json_pointer;
  CHECK_THROWS_WITH_AS(nn::dav2_config_from_json(without(P("/hparams/encoder/dav2_params/target_input_size"))),
                       doctest::Contains("missing key hparams.encoder.dav2_params.target_input_size"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(nn::dav2_config_from_json(without(P("/dav2_config/backbone_config/out_indices"))),
                       doctest::Contains("missing key dav2_config.backbone_config.out_indices"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(nn::dav2_config_from_json(without(P("/dav2_config/fusion_hidden_size"))),
                       doctest::Contains("missing key dav2_config.fusion_hidden_size"), std::invalid_argument);
  CHECK_THROWS_WITH_AS(nn::dav2_config_from_json(without(P("/dav2_config"))), doctest::Contains("missing key dav2_config"),
                       std::invalid_argument);
  nlohmann::json bad = config;
  bad["dav2_config"]["reassemble_factors"][3] = 0.3;
  CHECK_THROWS_AS(nn::dav2_config_from_json(bad), std::invalid_argument);
}
