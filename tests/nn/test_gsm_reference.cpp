// The GSM's CPU reference stages owned by the model's front end — the conv
// image encoder, the effective mask and the sky (token, image, panorama) —
// against the official gsm_small case (../shared/data/models/gsm_small): every
// traced intermediate and output within 1e-4 of its std.
#include <doctest/doctest.h>

#include "gsm_case.h"
#include "nn/gsm/conv_encoder_reference.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/sky_reference.h"
#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <string>

using namespace icube;

namespace {

nlohmann::json case_hparams(const std::string& dir) {
  return nlohmann::json::parse(scene::read_file(dir + "config.json")).at("hparams");
}

}  // namespace

TEST_CASE("gsm reference: the conv image encoder and the effective mask match enc.conv.* and enc.effective_mask") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  nn::GsmTrace trace;
  nn::CpuTensor out = nn::conv_encoder_forward(nn::conv_encoder_config_from_json(case_hparams(dir)), w, nn::gsm_images_nchw(in), &trace);
  for (int i = 0; i < 3; ++i) {
    const std::string name = "enc.conv.project_head." + std::to_string(i);
    REQUIRE(trace.tensors.count(name));
    test::check_gsm_tensor(ref, name, trace.tensors.at(name));
  }
  out.shape.insert(out.shape.begin(), in.batch);
  out.shape[1] = in.views;
  test::check_gsm_tensor(ref, "enc.conv.out", out);
  nn::CpuTensor effective = nn::gsm_effective_mask(in);
  test::check_gsm_tensor(ref, "enc.effective_mask", effective);
}

TEST_CASE("gsm reference: the sky token, sky image and panorama match sky.* and the outputs") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const test::GsmTensors ref(dir + "intermediates.safetensors"), out(dir + "outputs.safetensors");
  const nn::SkyConfig c = nn::sky_config_from_json(case_hparams(dir));
  nn::GsmTrace trace;
  const nn::CpuTensor tokens = nn::sky_tokens(c, w, in, nn::gsm_images_nchw(in), &trace);
  for (const char* name : {"sky.patch_embed", "sky.valid_patch_mask", "sky.pos_embed.in", "sky.pos_embed", "sky.tokens_in.b0",
                           "sky.tokens_out.b0"}) {
    REQUIRE_MESSAGE(trace.tensors.count(name), name);
    test::check_gsm_tensor(ref, name, trace.tensors.at(name));
  }
  test::check_gsm_tensor(out, "sky.tokens", tokens);
  test::check_gsm_tensor(out, "sky.image", nn::sky_image(c, w, in, tokens));
  test::check_gsm_tensor(out, "sky.panorama", nn::sky_panorama(c, w, tokens, 256));
}
