// The CPU reference of the structure VAE (engine/nn/vae_reference.h): the
// official vae_small decode, the configuration and its parameter list, the
// fVDB 0.2.0 kernel-axis order, the all-empty structure decision, and an
// encode -> decode round of a small random-weight model.
#include "gpu_test_context.h"
#include "nn/random_weights.h"
#include "nn/safetensors.h"
#include "nn/vae_config.h"
#include "nn/vae_reference.h"
#include "nn/vae_weights.h"
#include "scene/input_error.h"
#include "vae_case_check.h"

#include <doctest/doctest.h>

#include <numeric>
#include <random>

using namespace icube;
using nn::Ijk;

namespace {

// A narrow model of the released structure (3 levels, pooling [2,2,1] then [2,2,2]), 4 latent channels.
nn::VaeConfig tiny_config() {
  return nn::parse_vae_config(R"({"vae_kwargs": {"cut_ratio": 8, "with_normal_branch": false,
    "with_semantic_branch": true, "in_channels": 8, "num_blocks": 3, "f_maps": 8, "neck_dense_type": "HAND_CRAFTED",
    "neck_bound": [4, 4, 3], "num_res_blocks": 1, "use_residual": true, "order": "gcs", "is_add_dec": true,
    "use_attention": false, "use_checkpoint": false, "pooling_level": [2]},
    "encoder_kwargs": {"num_semantic": 23, "dim_semantic": 6}})",
                                 "tiny_vae.json");
}

}  // namespace

TEST_CASE("vae reference: vae_small decodes as the official StructPredictionNet, every level") {
  const std::string dir = test::test_data_dir();
  if (dir.empty()) return;
  const std::string m = dir + "/models/vae_small/";
  const nn::VaeConfig cfg = nn::load_vae_config(m + "config.json");
  CHECK(cfg.latent_channels() == 8);
  CHECK(cfg.features() == std::vector<int>{32, 32, 64, 128});
  const nn::SafetensorsFile file(m + "vae_weights.safetensors");
  // The file holds the StructPredictionNet (unet.*) only: every one of its 102 tensors is a parameter.
  CHECK(file.tensors().size() == 102);
  const nn::VaeReference vae(cfg, nn::load_vae_weights_cpu(file, cfg, nn::VaePart::Decoder));
  const nn::VaeDecoded d = vae.decode(test::vae_small_latent(m));
  const test::VaeCaseResult r = test::check_vae_small_decode(m, d);
  MESSAGE("vae_small decode (CPU reference): " << r.voxels << " voxels; structure logits max |d| / std " << r.worst_struct
                                               << ", semantic " << r.semantic << " (bound 1e-4)");
}

TEST_CASE("vae reference: configuration, parameter lists and the released preset") {
  const nn::VaeConfig rel = nn::load_vae_config("infinicube-vae");
  const std::vector<nn::ParamSpec> all = nn::vae_param_specs(rel, nn::VaePart::All);
  auto count = [](const std::vector<nn::ParamSpec>& ps) {
    int64_t n = 0;
    for (const nn::ParamSpec& p : ps) n += nn::CpuTensor::count(p.shape);
    return n;
  };
  // ../shared/reference/models/vae.tsv: 107 tensors, 19,593,021 parameters, decoder path 10,611,885.
  CHECK(all.size() == 107);
  CHECK(count(all) == 19593021);
  CHECK(count(nn::vae_param_specs(rel, nn::VaePart::Decoder)) == 10611885);
  CHECK(rel.latent_channels() == 8);
  CHECK(rel.pool_factor(1) == Ijk{2, 2, 1});
  CHECK(rel.pool_factor(2) == Ijk{2, 2, 2});
  CHECK(rel.subdivide_factor(1) == Ijk{2, 2, 2});  // Up-2: depth 2 -> 1
  CHECK(rel.subdivide_factor(0) == Ijk{2, 2, 1});  // Up-3: depth 1 -> 0
  auto bad = [](const std::string& json) { return nn::parse_vae_config(json, "bad.json"); };
  const std::string base = R"("in_channels": 32, "num_blocks": 3)";
  CHECK_THROWS_WITH_AS(bad("{" + base + R"(, "use_attention": true})"), doctest::Contains("bad.json: use_attention: sparse attention"),
                       scene::InputError);
  CHECK_THROWS_WITH_AS(bad("{" + base + R"(, "colour": 1})"), doctest::Contains("colour: is not a StructPredictionNet argument"),
                       scene::InputError);
  CHECK_THROWS_WITH_AS(bad("{" + base + R"(, "order": "gxs", "with_semantic_branch": true})"), doctest::Contains("order"),
                       scene::InputError);
  CHECK_THROWS_WITH_AS(bad(R"({"num_blocks": 3})"), doctest::Contains("needs in_channels"), scene::InputError);
  CHECK_THROWS_WITH_AS(bad("{" + base + R"(, "cut_ratio": 7, "with_semantic_branch": true})"), doctest::Contains("cut_ratio"),
                       scene::InputError);
  CHECK_THROWS_AS(bad("{" + base + ", "), scene::InputError);
}

TEST_CASE("vae reference: fVDB 0.2.0 kernels run in reverse grid order, converted in one place") {
  // An asymmetric kernel on an asymmetric grid: the engine's grid-order conv with the converted weight
  // equals fVDB 0.2.0's definition out[i,j,k] = sum W[:, :, dk+1, dj+1, di+1] in[i+di, j+dj, k+dk].
  std::mt19937 rng(21);
  std::normal_distribution<float> n(0.0f, 1.0f);
  nn::SparseTensor x;
  x.grid = nn::dense_box_grid({-2, 0, 3}, {5, 3, 4}, {1, 1, 1}, {0, 0, 0});
  x.grid.ijk.erase(x.grid.ijk.begin() + 7);  // not fully dense
  x.channels = 2;
  x.data.resize(static_cast<size_t>(x.rows() * 2));
  for (float& v : x.data) v = n(rng);
  nn::CpuTensor stored({3, 2, 3, 3, 3});
  for (float& v : stored.data) v = n(rng);
  const nn::SparseTensor y = nn::cpu::conv3d(x, nn::fvdb020_kernel_to_grid_order(stored), nullptr);
  const std::vector<int32_t> map = nn::cpu::kernel_map(x.grid, 3);
  double worst = 0.0;
  for (int64_t r = 0; r < x.rows(); ++r)
    for (int64_t o = 0; o < 3; ++o) {
      double s = 0.0;
      for (int di = -1; di <= 1; ++di)
        for (int dj = -1; dj <= 1; ++dj)
          for (int dk = -1; dk <= 1; ++dk) {
            const int32_t src = map[static_cast<size_t>(r * 27 + ((di + 1) * 3 + dj + 1) * 3 + dk + 1)];
            if (src < 0) continue;
            for (int64_t c = 0; c < 2; ++c)
              s += double{stored.data[static_cast<size_t>((((o * 2 + c) * 3 + dk + 1) * 3 + dj + 1) * 3 + di + 1)]} * double{x.row(src)[c]};
          }
      worst = std::max(worst, std::abs(s - double{y.row(r)[o]}));
    }
  CHECK(worst < 1e-5);
  // Reading the same weight in grid order would be a different (wrong) network.
  const nn::SparseTensor wrong = nn::cpu::conv3d(x, stored, nullptr);
  double diff = 0.0;
  for (size_t i = 0; i < y.data.size(); ++i) diff = std::max(diff, std::abs(double{wrong.data[i]} - double{y.data[i]}));
  CHECK(diff > 0.1);
}

TEST_CASE("vae reference: an all-empty structure decision decodes to an empty chunk with a warning") {
  const nn::VaeConfig cfg = tiny_config();
  std::map<std::string, nn::CpuTensor> w = nn::random_weights(nn::vae_param_specs(cfg, nn::VaePart::Decoder), 3);
  // Struct-1 says "drop" everywhere: logit1 >> logit0.
  w.at("unet.struct_convs.Struct-1.OutConv.bias").data = {-100.0f, 100.0f};
  const nn::VaeReference vae(cfg, std::move(w));
  nn::SparseTensor latent;
  latent.grid = nn::dense_box_grid({-4, -4, -3}, {8, 8, 6}, {0.8, 0.8, 0.4}, {0.4, 0.4, 0.2});
  latent.channels = cfg.latent_channels();
  latent.data.assign(static_cast<size_t>(latent.rows() * latent.channels), 0.5f);
  const nn::VaeDecoded d = vae.decode(latent);
  CHECK(d.warning.find("kept no voxel") != std::string::npos);
  CHECK(d.semantic.rows() == 0);
  CHECK(d.semantic.channels == 23);
  CHECK(d.levels[0].grid.size() == 0);
}

TEST_CASE("vae reference: encode a chunk to the dense neck latent and decode it again") {
  const nn::VaeConfig cfg = tiny_config();
  const nn::VaeReference vae(cfg, nn::random_weights(nn::vae_param_specs(cfg, nn::VaePart::All), 11));
  // A ground slab and a box at 0.2 m inside the neck's reach: fine ijk in [-16, 16) x [-16, 16) x [-6, 6).
  nn::SparseGrid fine;
  fine.voxel_size = {0.2, 0.2, 0.2};
  fine.origin = {0.1, 0.1, 0.1};
  std::vector<int32_t> classes;
  for (int32_t i = -16; i < 16; ++i)
    for (int32_t j = -16; j < 16; ++j) {
      fine.ijk.push_back({i, j, -4});
      classes.push_back(17);  // road
      if (i >= 2 && i < 6 && j >= -3 && j < 3)
        for (int32_t k = -3; k < 2; ++k) fine.ijk.push_back({i, j, k}), classes.push_back(1);  // car
    }
  std::vector<int64_t> perm = nn::sort_brick_order(fine);
  std::vector<int32_t> sorted(classes.size());
  for (size_t r = 0; r < perm.size(); ++r) sorted[r] = classes[static_cast<size_t>(perm[r])];
  const nn::SparseTensor mu = vae.encode(fine, sorted);
  // Neck box [-4, 4) x [-4, 4) x [-3, 3) at the latent level (0.8 x 0.8 x 0.4 m), 4 channels.
  CHECK(mu.rows() == 8 * 8 * 6);
  CHECK(mu.channels == 4);
  CHECK(mu.grid.voxel_size[0] == doctest::Approx(0.8));
  CHECK(mu.grid.voxel_size[2] == doctest::Approx(0.4));
  CHECK(mu.grid.origin[0] == doctest::Approx(0.4));
  CHECK(mu.grid.origin[2] == doctest::Approx(0.2));
  for (const float v : mu.data) CHECK(std::isfinite(v));
  const nn::VaeDecoded d = vae.decode(mu);
  CHECK(d.levels[2].grid.size() == mu.rows());
  // Each level holds the kept voxels of the one above, subdivided [2,2,2] then [2,2,1].
  auto kept = [&](int depth) {
    const nn::VaeLevel& l = d.levels[static_cast<size_t>(depth)];
    int64_t k = 0;
    for (int64_t r = 0; r < l.grid.size(); ++r) k += l.logits[static_cast<size_t>(2 * r)] > l.logits[static_cast<size_t>(2 * r + 1)];
    return k;
  };
  CHECK(d.levels[1].grid.size() == kept(2) * 8);
  CHECK(d.levels[0].grid.size() == kept(1) * 4);
  CHECK(d.semantic.rows() == kept(0));
  CHECK(d.levels[0].grid.voxel_size[0] == doctest::Approx(0.2));
  CHECK(d.levels[0].grid.voxel_size[2] == doctest::Approx(0.2));
  // Position embedding order: [p, sin p, cos p, sin 2p, cos 2p, ...].
  const std::vector<float> pe = nn::position_embedding({0.5f, -1.0f, 2.0f}, 2);
  REQUIRE(pe.size() == 15);
  CHECK(pe[0] == 0.5f);
  CHECK(pe[3] == doctest::Approx(std::sin(0.5)));
  CHECK(pe[6] == doctest::Approx(std::cos(0.5)));
  CHECK(pe[10] == doctest::Approx(std::sin(-2.0)));
  CHECK(pe[11] == doctest::Approx(std::sin(4.0)));
  CHECK(pe[14] == doctest::Approx(std::cos(4.0)));
}
