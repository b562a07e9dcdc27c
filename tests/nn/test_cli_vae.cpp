// `icube nn vae decode` (tools/cmd_nn_vae.cpp): the vae_small latent decodes to
// the official voxels, level by level through --dump-layers and as a .icw
// world; bad latents and weights are one-line errors that leave no output.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gpu_test_context.h"
#include "nn/layers_cpu.h"
#include "nn/safetensors.h"
#include "nn/sparse_cpu.h"
#include "world/npy.h"
#include "world/world_file.h"

#include <cmath>
#include <filesystem>
#include <string>

using namespace icube;

namespace {

// Rows of b's ijk in a's (both [N, 3] int32 .npy); all present and the counts equal.
std::vector<int32_t> rows_of(const world::NpyArray& a, const world::NpyArray& b) {
  nn::SparseGrid g;
  const std::vector<int32_t> av = a.values<int32_t>(), bv = b.values<int32_t>();
  for (size_t r = 0; r < av.size() / 3; ++r) g.ijk.push_back({av[3 * r], av[3 * r + 1], av[3 * r + 2]});
  std::vector<nn::Ijk> q;
  for (size_t r = 0; r < bv.size() / 3; ++r) q.push_back({bv[3 * r], bv[3 * r + 1], bv[3 * r + 2]});
  CHECK(g.ijk.size() == q.size());
  const std::vector<int32_t> rows = nn::cpu::find_rows(g, q);
  CHECK(std::count(rows.begin(), rows.end(), -1) == 0);
  return rows;
}

double logits_error(const world::NpyArray& got, const std::vector<int32_t>& rows, const world::NpyArray& ref) {
  const std::vector<float> g = got.values<float>(), r = ref.values<float>();
  const size_t c = ref.shape[1];
  std::vector<float> picked(r.size());
  for (size_t i = 0; i < rows.size(); ++i)
    if (rows[i] >= 0) std::copy_n(g.begin() + static_cast<int64_t>(rows[i] * c), c, picked.begin() + static_cast<int64_t>(i * c));
  return nn::cpu::max_abs_over_std(picked, r);
}

}  // namespace

TEST_CASE("cli: icube nn vae decode reproduces vae_small level by level; bad inputs leave no output") {
  const std::string cfg = test::test_data_file("models/vae_small/config.json");
  if (cfg.empty()) return;
  const std::string dir = std::filesystem::path(cfg).parent_path().string() + "/";
  test::TempDir tmp("cli-vae");
  const std::string out = (tmp.path / "chunk.icw").string(), dump = (tmp.path / "layers").string();
  const std::string common = "nn vae decode --model '" + cfg + "' --weights '" + dir + "vae_weights.safetensors' ";
  test::CliRun r = test::run_icube(common + "'" + dir + "small.latent.npy' --dump-layers '" + dump + "' -o '" + out + "'", tmp.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("2284 voxels at 0.20 m") != std::string::npos);
  CHECK(r.output.find("depth 2: 2048, depth 1: 8488, depth 0: 2568") != std::string::npos);
  for (const std::string level : {"struct2", "struct1", "struct0"}) {
    CAPTURE(level);
    const world::NpyArray ijk = world::read_npy(dump + "/" + level + ".ijk.npy");
    const std::vector<int32_t> rows = rows_of(ijk, world::read_npy(dir + "small." + level + ".ijk.npy"));
    CHECK(logits_error(world::read_npy(dump + "/" + level + ".logits.npy"), rows,
                       world::read_npy(dir + "small." + level + ".logits.npy")) <= 1e-4);
  }
  const std::vector<int32_t> rows = rows_of(world::read_npy(dump + "/ijk.npy"), world::read_npy(dir + "small.ijk.npy"));
  CHECK(logits_error(world::read_npy(dump + "/semantic.npy"), rows, world::read_npy(dir + "small.semantic.npy")) <= 1e-4);
  // The world: every decoded voxel but the 185 whose argmax is class 0, centres at ijk * 0.2 + 0.1.
  const world::VoxelGrid w = world::load_world(out);
  CHECK(w.voxel_count() == 2284 - 185);
  CHECK(w.voxel_size() == doctest::Approx(0.2));
  const glm::dvec3 c = w.ijk_to_world(glm::ivec3(-32, -30, -7));
  CHECK(c.x == doctest::Approx(-32 * 0.2 + 0.1));
  CHECK(c.z == doctest::Approx(-7 * 0.2 + 0.1));

  // Bad inputs: one-line errors, no output written.
  const std::string out2 = (tmp.path / "bad.icw").string(), dump2 = (tmp.path / "bad-layers").string();
  const std::string wrong = (tmp.path / "wrong.npy").string(), nan = (tmp.path / "nan.npy").string();
  world::write_npy(wrong, world::NpyArray::make<float>({1, 7, 2, 2, 2}, std::vector<float>(56, 0.0f)));
  std::vector<float> nv(8 * 8, 0.0f);
  nv[13] = std::nanf("");
  world::write_npy(nan, world::NpyArray::make<float>({1, 8, 2, 2, 2}, nv));
  r = test::run_icube(common + "'" + wrong + "' --dump-layers '" + dump2 + "' -o '" + out2 + "'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("wrong.npy: expected float32 [1, 8, X, Y, Z]") != std::string::npos);
  r = test::run_icube(common + "'" + nan + "' -o '" + out2 + "'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("nan.npy: element 13: is not finite") != std::string::npos);
  r = test::run_icube("nn vae decode --model infinicube-vae --weights '" + dir + "vae_weights.safetensors' '" + dir +
                          "small.latent.npy' -o '" + out2 + "'",
                      tmp.path);
  CHECK(r.code != 0);  // the released widths do not match the small file
  CHECK(r.output.find("vae_weights.safetensors: tensor 'unet.post_kl_bottleneck.post_kl_bottleneck_0.conv1.Conv.weight': shape") !=
        std::string::npos);
  r = test::run_icube(common + "'" + dir + "small.latent.npy' --latent-origin 1,2 -o '" + out2 + "'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("--latent-origin '1,2' is not I,J,K") != std::string::npos);
  CHECK(!std::filesystem::exists(out2));
  CHECK(!std::filesystem::exists(dump2));
  CHECK(test::run_icube("nn vae decode --help", tmp.path).code == 0);
}
