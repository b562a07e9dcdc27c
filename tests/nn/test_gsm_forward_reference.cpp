// The GSM's whole CPU reference (nn/gsm/gsm_reference.h) on the official
// gsm_small case, from its inputs alone: every output (both branches'
// Gaussians with equal counts and source indices, the sky token, image and
// panorama) and every one of the reference's intermediates within 1e-4 of its
// std; and the config and input checks that refuse what the model cannot run.
#include <doctest/doctest.h>

#include "gsm_case.h"
#include "nn/gsm/gsm_reference.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <functional>
#include <set>
#include <string>

using namespace icube;

TEST_CASE("gsm reference: the whole forward from gsm_small's inputs matches every output and intermediate") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmConfig c = nn::read_gsm_config(dir + "config.json");
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  nn::check_gsm_inputs(c, in, dir + "inputs");
  nn::GsmTrace trace;
  const auto t0 = std::chrono::steady_clock::now();
  const nn::GsmOutputs out = nn::gsm_forward_reference(c, w, in, &trace);
  MESSAGE("gsm_small forward (CPU reference): " << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s");
  const test::GsmTensors ref_out(dir + "outputs.safetensors"), ref_mid(dir + "intermediates.safetensors");
  // Outputs, by name, through the writer's tensors (so the names and dtypes the CLI writes are the ones checked).
  std::set<std::string> seen;
  for (const nn::TensorToWrite& t : nn::gsm_output_tensors(out)) {
    REQUIRE_MESSAGE(ref_out.has(t.name), "the reference has no output " << t.name);
    const nn::SafetensorsFile one = nn::SafetensorsFile::from_bytes(nn::safetensors_bytes({t}), t.name);
    test::check_gsm_tensor(ref_out, t.name, nn::CpuTensor(t.shape, one.to_f32(one.tensors().front())));
    CHECK((t.dtype == nn::DType::I32) == ref_out.is_integer(t.name));
    seen.insert(t.name);
  }
  CHECK(seen.size() == 17);  // every output of the one-element case
  // Every intermediate the reference recorded was traced, and agrees.
  size_t checked = 0;
  for (const auto& [name, tensor] : trace.tensors) {
    if (!ref_mid.has(name)) continue;
    test::check_gsm_tensor(ref_mid, name, tensor);
    ++checked;
  }
  CHECK_MESSAGE(checked >= 100, "only " << checked << " of the reference's intermediates were traced");
}

TEST_CASE("gsm reference: configs and inputs the model cannot run are refused with the key or file named") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nlohmann::json good = nlohmann::json::parse(scene::read_file(dir + "config.json"));
  auto refused = [&](const std::function<void(nlohmann::json&)>& edit, const std::string& words) {
    nlohmann::json j = good;
    edit(j);
    try {
      nn::gsm_config_from_json(j, "cfg.json");
      FAIL("accepted: " << words);
    } catch (const scene::InputError& e) {
      CHECK_MESSAGE(std::string(e.what()).find("cfg.json") != std::string::npos, std::string(e.what()));
      CHECK_MESSAGE(std::string(e.what()).find(words) != std::string::npos, std::string(e.what()));
    }
  };
  refused([](nlohmann::json& j) { j["hparams"]["encoder"]["resize_projection_input"] = true; }, "resize_projection_input");
  refused([](nlohmann::json& j) { j["hparams"]["backbone"]["params"]["use_3d"] = false; }, "use_3d");
  refused([](nlohmann::json& j) { j["hparams"].erase("encoder"); }, "encoder");
  refused([](nlohmann::json& j) { j["hparams"]["skybox_target"] = "panorama_full"; }, "skybox_target");
  refused([](nlohmann::json& j) { j["hparams"]["backbone"]["params"]["backbone_3d_params"]["lifter_params"]["img_in_dim"] = 8; },
          "img_in_dim");
  // Inputs whose intrinsics disagree with the images.
  nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  in.intrinsics[0][4] = 200.0f;
  CHECK_THROWS_AS(nn::check_gsm_inputs(nn::gsm_config_from_json(good, "cfg.json"), in, "case"), scene::InputError);
}
