// tools/convert_checkpoint.py on GSM checkpoints: a synthetic Lightning checkpoint
// laid out as InfiniCube's released GSM checkpoint, made from the gsm_small case
// (tests/nn/make_synthetic_gsm_checkpoint.py: the case's weights, its hparams
// pickled as an OmegaConf DictConfig with the training configs' unresolved
// interpolations, loss.* tensors and optimizer junk), converts into
// gsm.safetensors (every weight byte for byte, num_batches_tracked as I64) and
// gsm_config.json (the case's hparams and Depth-Anything config exactly) that
// drive the CPU reference (nn/gsm/gsm_reference.h) to gsm_small's outputs; and
// checkpoints whose hparams contradict their weights, or that are not a GSM,
// are refused with one line naming the key and no output. Making the
// checkpoints needs Debian's python3-torch (tools/install-deps.sh --test); the
// converter needs numpy only.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "gsm_case.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/gsm_reference.h"
#include "nn/safetensors.h"
#include "scene/atomic_file.h"

using namespace icube;

namespace {

// A python3 with torch, or empty after reporting the skip (a failure when ICUBE_REQUIRE_DATA=1).
std::string python_with_torch() {
  const std::string py = test::python_with("torch, numpy");
  if (py.empty()) {
    const char* req = std::getenv("ICUBE_REQUIRE_DATA");
    if (req && std::string(req) == "1")
      FAIL("python3 with torch is missing (tools/install-deps.sh --test installs python3-torch)");
    MESSAGE("skipped: no python3 with torch (apt install python3-torch)");
  }
  return py;
}

struct Tools {
  std::string make, convert;
};

Tools tools(const std::string& py, const std::string& case_dir) {
  const std::string src = ICUBE_SOURCE_DIR;
  return {py + " " + src + "/tests/nn/make_synthetic_gsm_checkpoint.py " + case_dir + " ",
          py + " " + src + "/tools/convert_checkpoint.py "};
}

nlohmann::json read_json(const std::string& path) { return nlohmann::json::parse(scene::read_file(path)); }

}  // namespace

TEST_CASE(
    "gsm convert_checkpoint: a Lightning GSM checkpoint converts into weights and a config that reproduce gsm_small") {
  const std::string py = python_with_torch();
  if (py.empty()) return;
  const std::string case_dir = test::gsm_small_dir();
  if (case_dir.empty()) return;
  const Tools t = tools(py, case_dir);
  test::TempDir tmp("convert-gsm");
  const std::string dir = tmp.path.string();
  const auto [mrc, mout] = test::run_shell(t.make + dir + "/gsm.ckpt");
  REQUIRE_MESSAGE(mrc == 0, mout);
  MESSAGE("synthetic checkpoint: " << mout);
  const auto [rc, out] = test::run_shell(t.convert + dir + "/gsm.ckpt -o " + dir + "/gsm --dav2-heads 4");
  INFO(out);
  REQUIRE(rc == 0);
  CHECK(out.find("gsm.safetensors: 501 tensors (backbone, img_encoder, skybox)") != std::string::npos);
  CHECK(out.find("left out: 2 entries (loss)") != std::string::npos);
  CHECK(out.find("inert placeholders") == std::string::npos);  // the DictConfig, its nodes and metadata are all read

  // The config: the case's hparams (interpolations resolved) and its Depth-Anything config read off the weights.
  const nlohmann::json want = read_json(case_dir + "config.json");
  const nlohmann::json got = read_json(dir + "/gsm/gsm_config.json");
  CHECK(got.at("hparams") == want.at("hparams"));
  CHECK(got.at("dav2_config") == want.at("dav2_config"));
  CHECK(got.at("dav2_name_registered") == want.at("dav2_name_registered"));
  CHECK(got.at("hparams").at("train_kwargs").at("attr_subfolders") == want.at("hparams").at("_attr_subfolders"));

  // The weights: every tensor of the case, same dtype and bytes (num_batches_tracked stays I64), nothing else.
  const nn::SafetensorsFile converted(dir + "/gsm/gsm.safetensors"), original(case_dir + "weights.safetensors");
  CHECK(converted.tensors().size() == original.tensors().size());
  size_t int64_buffers = 0;
  for (const nn::TensorInfo& w : original.tensors()) {
    const nn::TensorInfo* c = converted.find(w.name);
    REQUIRE_MESSAGE(c != nullptr, w.name);
    CHECK_MESSAGE(c->dtype == w.dtype, w.name);
    CHECK_MESSAGE(c->shape == w.shape, w.name);
    const auto a = converted.bytes(*c), b = original.bytes(w);
    CHECK_MESSAGE(std::equal(a.begin(), a.end(), b.begin(), b.end()), w.name);
    int64_buffers += c->dtype == nn::DType::I64;
  }
  CHECK(int64_buffers == 9);
  CHECK(converted.metadata().at("model") == "gsm");

  // The converted pair drives the reference to the case's outputs.
  const nn::GsmConfig config = nn::read_gsm_config(dir + "/gsm/gsm_config.json");
  const nn::GsmWeights weights = nn::load_gsm_weights(dir + "/gsm/gsm.safetensors");
  const nn::GsmInputs in = nn::read_gsm_inputs(case_dir + "inputs");
  nn::check_gsm_inputs(config, in, case_dir + "inputs");
  const nn::GsmOutputs outputs = nn::gsm_forward_reference(config, weights, in, nullptr);
  const test::GsmTensors ref(case_dir + "outputs.safetensors");
  size_t checked = 0;
  for (const nn::TensorToWrite& o : nn::gsm_output_tensors(outputs)) {
    REQUIRE_MESSAGE(ref.has(o.name), "the reference has no output " << o.name);
    const nn::SafetensorsFile one = nn::SafetensorsFile::from_bytes(nn::safetensors_bytes({o}), o.name);
    test::check_gsm_tensor(ref, o.name, nn::CpuTensor(o.shape, one.to_f32(one.tensors().front())));
    ++checked;
  }
  CHECK(checked == 17);
}

TEST_CASE("gsm convert_checkpoint: without --dav2-heads the heads are DINOv2's 64-wide ones, named as assumed") {
  const std::string py = python_with_torch();
  if (py.empty()) return;
  const std::string case_dir = test::gsm_small_dir();
  if (case_dir.empty()) return;
  const Tools t = tools(py, case_dir);
  test::TempDir tmp("convert-gsm-heads");
  const std::string dir = tmp.path.string();
  // The stand-in DictConfig (what a machine without python3-omegaconf pickles) reads the same.
  const auto [mrc, mout] = test::run_shell(t.make + dir + "/gsm.ckpt --emulate-omegaconf");
  REQUIRE_MESSAGE(mrc == 0, mout);
  const auto [rc, out] = test::run_shell(t.convert + dir + "/gsm.ckpt -o " + dir + "/gsm");
  INFO(out);
  REQUIRE(rc == 0);
  CHECK(out.find("assumed: num_attention_heads 1 (DINOv2's 64-wide heads; --dav2-heads sets it)") != std::string::npos);
  const nlohmann::json want = read_json(case_dir + "config.json");
  nlohmann::json got = read_json(dir + "/gsm/gsm_config.json");
  CHECK(got.at("hparams") == want.at("hparams"));
  CHECK(got["dav2_config"]["backbone_config"]["num_attention_heads"] == 1);
  got["dav2_config"]["backbone_config"]["num_attention_heads"] = 4;
  CHECK(got.at("dav2_config") == want.at("dav2_config"));  // everything else read off the weights
}

TEST_CASE("gsm convert_checkpoint: hparams that contradict the weights, and checkpoints that are no GSM, are refused") {
  const std::string py = python_with_torch();
  if (py.empty()) return;
  const std::string case_dir = test::gsm_small_dir();
  if (case_dir.empty()) return;
  const Tools t = tools(py, case_dir);
  test::TempDir tmp("convert-gsm-bad");
  const std::string dir = tmp.path.string();
  struct Bad {
    std::string make_args, message;
  };
  const std::vector<Bad> cases = {
      {"--set encoder.conv_params.conv_encoder_out_dim=32",
       "hyper_parameters encoder.conv_params.conv_encoder_out_dim: says 32, the weights hold 16"},
      {"--set 'encoder.conv_params.n_filter_list=[3,8,16,32]' --emulate-omegaconf",
       "hyper_parameters encoder.conv_params.n_filter_list: says [3, 8, 16, 32], the weights hold [3, 8, 16, 16]"},
      {"--set backbone.params.backbone_3d_params.f_maps=32",
       "hyper_parameters backbone.params.backbone_3d_params.f_maps: says 32, the weights hold 16"},
      {"--set backbone.params.backbone_2d_params.unet2d_params.dim=16",
       "hyper_parameters backbone.params.backbone_2d_params.unet2d_params.dim: says 16, the weights hold 8"},
      {"--set skybox_mlp_modulator.embed_dim=64 --plain-hparams",
       "hyper_parameters skybox_mlp_modulator.embed_dim: says 64, the weights hold 32"},
      {"--drop img_encoder.encoders.dav2.",
       "hyper_parameters encoder.encoder_modules: says [\"conv\", \"dav2\"], the weights hold [\"conv\"]"},
      {"--weights-of-unet", "state_dict: has no img_encoder.* tensors: not an InfiniCube GSM's weights"},
      {"--model vae", "hyper_parameters model: says \"vae\", the weights are a GSM's"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const Bad& b = cases[i];
    const std::string ckpt = dir + "/bad" + std::to_string(i) + ".ckpt", outdir = dir + "/bad" + std::to_string(i);
    const auto [mrc, mout] = test::run_shell(t.make + ckpt + " " + b.make_args);
    INFO(mout);
    REQUIRE(mrc == 0);
    const auto [rc, out] = test::run_shell(t.convert + ckpt + " -o " + outdir + " --dav2-heads 4");
    INFO(i, ": ", out);
    CHECK(rc == 1);
    CHECK(out.find(ckpt + ": ") != std::string::npos);
    CHECK(out.find(b.message) != std::string::npos);
    CHECK(std::count(out.begin(), out.end(), '\n') == 1);
    CHECK_FALSE(std::filesystem::exists(outdir));
  }
}
