// `icube nn vae decode` (tools/cmd_nn_vae.cpp): the vae_small latent decodes to
// the official voxels, level by level through --dump-layers and as a .icw
// world; bad latents and weights are one-line errors that leave no output.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gpu_test_context.h"
#include "kernels/nn/cpu_tensor.h"
#include "nn/safetensors.h"
#include "kernels/nn/sparse_cpu.h"
#include "nn/random_weights.h"
#include "nn/vae_config.h"
#include "scene/atomic_file.h"
#include "scene/scene_json.h"
#include "world/demo_scene.h"
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
  glm::ivec3 v0(0);
  uint8_t cls = 0;
  w.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    if (cls == 0) v0 = ijk, cls = v.class_id;
  });
  REQUIRE(cls != 0);
  const glm::dvec3 p0 = w.ijk_to_world(v0);  // in the chunk frame

  // Placed into a world (--at): on the world lattice the cells are copied exactly; a quarter turn
  // re-voxelises (subdivided centres) onto the same number of cells, each at its rotated place.
  const std::string placed = (tmp.path / "placed.icw").string();
  const std::string latent = " '" + dir + "small.latent.npy' ";
  r = test::run_icube(common + latent + "--at 100,50.2,3 -o '" + placed + "'", tmp.path);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("placed at (100.00, 50.20, 3.00): 2099 world cells (the world lattice, copied exactly)") != std::string::npos);
  world::VoxelGrid pw = world::load_world(placed);
  CHECK(pw.voxel_count() == 2099);
  CHECK(pw.get(pw.world_to_ijk(glm::dvec3(100 + p0.x, 50.2 + p0.y, 3 + p0.z))).class_id == cls);
  r = test::run_icube(common + latent + "--at 100,50,3,90 -o '" + placed + "'", tmp.path);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("2099 world cells (re-voxelised)") != std::string::npos);
  pw = world::load_world(placed);
  CHECK(pw.voxel_count() == 2099);
  CHECK(pw.get(pw.world_to_ijk(glm::dvec3(100 - p0.y, 50 + p0.x, 3 + p0.z))).class_id == cls);  // chunk (x, y) -> world (-y, x)
  r = test::run_icube(common + latent + "--at 1,2,3 --chunk 0 -o '" + placed + "'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("give the chunk as --scene SCENE --chunk K, or as --at") != std::string::npos);

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

TEST_CASE("cli: icube nn vae encode a real world chunk, decode it again: structure sizes per level" * doctest::test_suite("slow-gpu")) {
  test::TempDir tmp("cli-vae-encode");
  const std::string scene = (tmp.path / "scene.json").string(), world_path = (tmp.path / "world.icw").string();
  scene::write_scene_json(world::make_demo_scene(), scene);
  test::CliRun r = test::run_icube("world build '" + scene + "' -o '" + world_path + "' 2>/dev/null", tmp.path);
  REQUIRE(r.code == 0);
  // A narrow model of the released structure with the released neck (64^3 latent box).
  const std::string cfg_json = R"({"vae_kwargs": {"cut_ratio": 8, "with_semantic_branch": true, "in_channels": 8,
    "num_blocks": 3, "f_maps": 8, "neck_dense_type": "HAND_CRAFTED", "neck_bound": [32, 32, 32], "num_res_blocks": 1,
    "use_residual": true, "order": "gcs", "is_add_dec": true, "pooling_level": [2]}, "encoder_kwargs": {"dim_semantic": 6}})";
  const std::string cfg = (tmp.path / "vae.json").string(), weights = (tmp.path / "vae.safetensors").string();
  scene::write_file_atomic(cfg, cfg_json);
  const nn::VaeConfig c = nn::parse_vae_config(cfg_json, cfg);
  std::vector<nn::TensorToWrite> tensors;
  for (const auto& [name, t] : nn::random_weights(nn::vae_param_specs(c, nn::VaePart::All), 3))
    tensors.push_back(nn::f32_tensor(name, t.shape, t.data));
  nn::write_safetensors(weights, tensors);
  const std::string latent = (tmp.path / "latent.npy").string();
  r = test::run_icube("nn vae encode '" + world_path + "' --scene '" + scene + "' --chunk 1 --model '" + cfg + "' --weights '" +
                          weights + "' --scale-factor 2 -o '" + latent + "'",
                      tmp.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("latent [1, 4, 64, 64, 64] from ijk (-32, -32, -32)") != std::string::npos);
  const world::NpyArray a = world::read_npy(latent);
  CHECK(a.shape == std::vector<uint64_t>{1, 4, 64, 64, 64});
  const std::string dump = (tmp.path / "layers").string(), chunk = (tmp.path / "chunk.icw").string();
  r = test::run_icube("nn vae decode '" + latent + "' --model '" + cfg + "' --weights '" + weights +
                          "' --scale-factor 2 --dump-layers '" + dump + "' -o '" + chunk + "'",
                      tmp.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  // Each level holds the kept voxels of the one above, subdivided [2,2,2] then [2,2,1]; the latent level
  // is the whole 64^3 box.
  auto kept = [&](int depth) {
    const std::vector<float> l = world::read_npy(dump + "/struct" + std::to_string(depth) + ".logits.npy").values<float>();
    uint64_t k = 0;
    for (size_t i = 0; i + 1 < l.size(); i += 2) k += l[i] > l[i + 1];
    return k;
  };
  auto rows = [&](int depth) { return world::read_npy(dump + "/struct" + std::to_string(depth) + ".ijk.npy").shape[0]; };
  CHECK(rows(2) == 64u * 64u * 64u);
  CHECK(rows(1) == kept(2) * 8);
  CHECK(rows(0) == kept(1) * 4);
  CHECK(world::read_npy(dump + "/ijk.npy").shape[0] == kept(0));
  // Bad chunk choices.
  r = test::run_icube("nn vae encode '" + world_path + "' --model '" + cfg + "' --weights '" + weights + "' -o '" + latent + ".2'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("give the chunk as --scene SCENE --chunk K, or as --at") != std::string::npos);
  r = test::run_icube("nn vae encode '" + world_path + "' --at 1e7,0,0 --model '" + cfg + "' --weights '" + weights + "' -o '" +
                          latent + ".2'",
                      tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("holds no voxel of the world") != std::string::npos);
  r = test::run_icube("nn vae encode '" + world_path + "' --at 1,2 --model '" + cfg + "' --weights '" + weights + "' -o '" + latent + ".2'",
                      tmp.path);
  CHECK(r.output.find("--at '1,2' is not X,Y,Z or X,Y,Z,YAW_DEG") != std::string::npos);
  CHECK(!std::filesystem::exists(latent + ".2"));
  CHECK(test::run_icube("nn vae encode --help", tmp.path).code == 0);
}
