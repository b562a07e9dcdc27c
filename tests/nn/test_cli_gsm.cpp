// `icube nn gsm forward` (tools/cmd_nn_gsm.cpp): the gsm_small case's outputs
// from its config, weights and inputs on the GPU (default) and the CPU
// reference, under the reference's names and dtypes, and every intermediate
// through --dump-layers (GPU); bad inputs are one-line errors
// naming the file that leave no output.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gsm_case.h"
#include "nn/safetensors.h"
#include "scene/atomic_file.h"
#include "world/npy.h"

#include <filesystem>
#include <string>

using namespace icube;

TEST_CASE("cli: icube nn gsm forward reproduces gsm_small's outputs and intermediates; bad inputs leave no output") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  test::TempDir tmp("cli-gsm");
  const std::string out = (tmp.path / "out.safetensors").string(), dump = (tmp.path / "layers.safetensors").string();
  const std::string common = "nn gsm forward --model '" + dir + "config.json' --weights '" + dir + "weights.safetensors' ";
  test::CliRun r = test::run_icube(common + "--inputs '" + dir + "inputs' --dump-layers '" + dump + "' -o '" + out + "'", tmp.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("56104 voxel and 3986 pixel Gaussians") != std::string::npos);
  const test::GsmTensors got(out), ref(dir + "outputs.safetensors");
  const nn::SafetensorsFile got_file(out), ref_file(dir + "outputs.safetensors");
  CHECK(got_file.tensors().size() == ref_file.tensors().size());
  for (const nn::TensorInfo& t : ref_file.tensors()) {
    REQUIRE_MESSAGE(got.has(t.name), t.name);
    CHECK_MESSAGE(got_file.find(t.name)->dtype == t.dtype, t.name);
    test::check_gsm_tensor(ref, t.name, got.get(t.name));
  }
  // The CPU reference through the same command.
  const std::string out_cpu = (tmp.path / "out_cpu.safetensors").string();
  test::CliRun rc = test::run_icube(common + "--backend cpu --inputs '" + dir + "inputs' -o '" + out_cpu + "'", tmp.path);
  INFO(rc.output);
  REQUIRE(rc.code == 0);
  CHECK(rc.output.find("CPU reference") != std::string::npos);
  const test::GsmTensors got_cpu(out_cpu);
  for (const nn::TensorInfo& t : ref_file.tensors()) test::check_gsm_tensor(ref, t.name, got_cpu.get(t.name));
  const test::GsmTensors layers(dump), ref_layers(dir + "intermediates.safetensors");
  const nn::SafetensorsFile ref_layers_file(dir + "intermediates.safetensors");
  for (const nn::TensorInfo& t : ref_layers_file.tensors()) {
    if (t.name == "pix.gaussian_pixel_mask_type" || t.name == "pix.depth_patch_keep") continue;  // inputs' echoes, not computed
    REQUIRE_MESSAGE(layers.has(t.name), "--dump-layers has no " << t.name);
    test::check_gsm_tensor(ref_layers, t.name, layers.get(t.name));
  }

  // A case folder with a broken file: one line naming it, no output written.
  const std::filesystem::path bad = tmp.path / "bad";
  std::filesystem::create_directories(bad);
  for (const auto& e : std::filesystem::directory_iterator(dir + "inputs")) std::filesystem::copy_file(e.path(), bad / e.path().filename());
  world::write_npy((bad / "poses.npy").string(), world::NpyArray::make<float>({1, 1, 4, 3}, std::vector<float>(12, 0.0f)));
  const std::string out2 = (tmp.path / "out2.safetensors").string();
  r = test::run_icube(common + "--inputs '" + bad.string() + "' -o '" + out2 + "'", tmp.path);
  INFO(r.output);
  CHECK(r.code != 0);
  CHECK(r.output.find("poses.npy") != std::string::npos);
  CHECK(r.output.find("shape [1, 1, 4, 3], expected [1, 1, 4, 4]") != std::string::npos);
  CHECK(!std::filesystem::exists(out2));
  // Weights with a tensor of the wrong shape: named, nothing written.
  r = test::run_icube("nn gsm forward --model '" + dir + "config.json' --weights '" + dir + "outputs.safetensors' --inputs '" + dir +
                          "inputs' -o '" + out2 + "'",
                      tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("outputs.safetensors") != std::string::npos);
  CHECK(r.output.find("missing") != std::string::npos);
  CHECK(!std::filesystem::exists(out2));
  // The released preset's widths against gsm_small's weights: refused before any work, the tensor named.
  r = test::run_icube("nn gsm forward --model infinicube-gsm --weights '" + dir + "weights.safetensors' --inputs '" + dir +
                          "inputs' -o '" + out2 + "'",
                      tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("project_head.0.0.weight") != std::string::npos);
  CHECK(!std::filesystem::exists(out2));
}
