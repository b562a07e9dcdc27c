// `icube nn random-weights --gsm-model` and `icube nn info --gsm-model`
// (tools/cmd_nn.cpp): random weights of gsm_small's structure (its config.json)
// in state-dict order with int64 batch counts, which info then finds complete;
// the official gsm_small weights checked against the released preset name the
// first tensor of another shape; a file with a tensor the GSM lacks is refused;
// two models at once are refused with no output.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gsm_case.h"
#include "nn/gsm/gsm_params.h"
#include "nn/safetensors.h"

#include <filesystem>
#include <string>

using namespace icube;

TEST_CASE("cli: icube nn random-weights and info with --gsm-model") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  test::TempDir tmp("cli-gsm-weights");
  const std::string cfg = dir + "config.json", w = (tmp.path / "gsm.safetensors").string();
  test::CliRun r = test::run_icube("nn random-weights --gsm-model '" + cfg + "' --seed 4 -o '" + w + "'", tmp.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("501 tensors, 2171870 parameters + 281 buffer elements") != std::string::npos);
  CHECK(r.output.find("random-weights: 501 tensors, 2171870 parameters (seed 4)") != std::string::npos);
  const nn::SafetensorsFile f(w);
  REQUIRE(f.tensors().size() == 501);
  const nn::TensorInfo* count = f.find("img_encoder.encoders.conv.project_head.0.1.num_batches_tracked");
  REQUIRE(count != nullptr);
  CHECK(count->dtype == nn::DType::I64);
  CHECK(count->shape.empty());

  r = test::run_icube("nn info '" + w + "' --gsm-model '" + cfg + "' --check-finite --limit 3", tmp.path);
  CHECK(r.code == 0);
  CHECK(r.output.find("holds every tensor of the GSM") != std::string::npos);
  CHECK(r.output.find("(501 tensors: 2171870 parameters, 281 buffer elements)") != std::string::npos);
  CHECK(r.output.find("all finite") != std::string::npos);

  // The official small weights against the released structure: the first tensor of another shape.
  r = test::run_icube("nn info '" + dir + "weights.safetensors' --gsm-model infinicube-gsm", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("tensor 'img_encoder.encoders.conv.project_head.0.0.weight': shape [8, 3, 3, 3], the GSM needs "
                      "[16, 3, 3, 3]") != std::string::npos);
  // ... and against their own config they are complete.
  r = test::run_icube("nn info '" + dir + "weights.safetensors' --gsm-model '" + cfg + "'", tmp.path);
  CHECK(r.code == 0);

  // A tensor the GSM does not have.
  const std::string extra = (tmp.path / "extra.safetensors").string();
  {
    std::vector<nn::TensorToWrite> t;
    for (const nn::TensorInfo& i : f.tensors()) {
      nn::TensorToWrite c;
      c.name = i.name;
      c.dtype = i.dtype;
      c.shape = i.shape;
      const auto bytes = f.bytes(i);
      c.bytes.assign(bytes.begin(), bytes.end());
      t.push_back(std::move(c));
    }
    t.push_back(nn::f32_tensor("skybox.skybox_net.0.weight", {1}, {0.0f}));
    nn::write_safetensors(extra, t);
  }
  r = test::run_icube("nn info '" + extra + "' --gsm-model '" + cfg + "'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("extra.safetensors: tensor 'skybox.skybox_net.0.weight': unexpected") != std::string::npos);

  // Two models at once: refused, nothing written.
  const std::string none = (tmp.path / "none.safetensors").string();
  r = test::run_icube("nn random-weights --gsm-model infinicube-gsm --vae-model infinicube-vae -o '" + none + "'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("give one of --model") != std::string::npos);
  CHECK(!std::filesystem::exists(none));
}
