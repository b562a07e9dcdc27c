// The whole GSM on the GPU (nn/gsm/gsm_gpu.h) on the official gsm_small case:
// every output (Gaussian counts and source indices equal) and every
// intermediate within 1e-4 of the reference's std, and a batch of two
// two-view elements and a model of other widths (seeded random weights)
// against the CPU reference. Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "nn/gsm/gsm_gpu.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_random_weights.h"
#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <string>

using namespace icube;


TEST_CASE("gsm gpu: the whole forward matches gsm_small's outputs and intermediates") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::gpu_context();
  const nn::GsmModelConfig model = nn::load_gsm_model_config(dir + "config.json");
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors", model, true);
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  nn::GsmGpu gsm(ctx, model.config, w);
  nn::GsmTrace trace;
  const nn::GsmOutputs out = gsm.forward(in, &trace);
  for (const nn::GsmGpu::Stage& s : gsm.last_stages()) MESSAGE(s.label << ": " << s.ms << " ms");
  const test::GsmTensors ref_out(dir + "outputs.safetensors"), ref_mid(dir + "intermediates.safetensors");
  size_t outputs = 0;
  for (const nn::TensorToWrite& t : nn::gsm_output_tensors(out)) {
    const nn::SafetensorsFile one = nn::SafetensorsFile::from_bytes(nn::safetensors_bytes({t}), t.name);
    test::check_gsm_tensor(ref_out, t.name, nn::CpuTensor(t.shape, one.to_f32(one.tensors().front())));
    ++outputs;
  }
  CHECK(outputs == 17);
  size_t checked = 0;
  for (const auto& [name, tensor] : trace.tensors) {
    if (!ref_mid.has(name)) continue;
    test::check_gsm_tensor(ref_mid, name, tensor);
    ++checked;
  }
  CHECK_MESSAGE(checked >= 100, "only " << checked << " of the reference's intermediates were traced");
}

TEST_CASE("gsm gpu: a batch of two two-view elements equals the CPU reference") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::gpu_context();
  const nn::GsmModelConfig model = nn::load_gsm_model_config(dir + "config.json");
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors", model, true);
  const nn::GsmInputs in = test::gsm_two_view_batch(dir);
  nn::GsmGpu gsm(ctx, model.config, w);
  const nn::GsmOutputs got = gsm.forward(in);
  const nn::GsmOutputs want = nn::gsm_forward_reference(model.config, w, in, nullptr);
  test::check_gsm_outputs(got, want, 1e-4);
}

TEST_CASE("gsm gpu: other widths with seeded random weights equal the CPU reference") {
  // gsm_small's structure with every width changed: conv encoder 3 -> 12 -> 24 -> 24 (output 24, so the
  // lifter's and heads' 2-D width 24), voxel U-Net 8 / 16 / 32 from 16 inputs, x-unet dim 16, sky tokens of
  // 48 (4 heads) with a 24-wide modulator, DINOv2 of 48 (4 heads, 3 layers: out indices 1..3 + the last).
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  nlohmann::json j = nlohmann::json::parse(scene::read_file(dir + "config.json"));
  nlohmann::json& h = j["hparams"];
  h["encoder"]["conv_params"]["n_filter_list"] = {3, 12, 24, 24};
  h["encoder"]["conv_params"]["conv_encoder_out_dim"] = 24;
  nlohmann::json& v = h["backbone"]["params"]["backbone_3d_params"];
  v["lifter_params"]["img_in_dim"] = 24;
  v["f_maps"] = 8;
  v["f_maps_2d"] = 24;
  h["backbone"]["params"]["backbone_2d_params"]["unet2d_params"]["dim"] = 16;
  h["backbone"]["params"]["backbone_2d_params"]["unet2d_params"]["init_dim"] = 16;
  h["skybox_mlp_modulator"]["embed_dim"] = 48;
  h["skybox_mlp_modulator"]["hidden_channels"] = 24;
  j["dav2_config"]["backbone_config"]["hidden_size"] = 48;
  j["dav2_config"]["backbone_config"]["num_hidden_layers"] = 3;
  j["dav2_config"]["backbone_config"]["out_indices"] = {1, 2, 3, 3};
  j["dav2_config"]["reassemble_hidden_size"] = 48;
  const nn::GsmModelConfig model = nn::gsm_model_config_from_json(j, "widths.json");
  const std::vector<nn::GsmParamSpec> specs = nn::gsm_param_specs(model);
  const nn::GsmWeights w = nn::gsm_random_weights(specs, 7);
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  nn::GsmGpu gsm(test::gpu_context(), model.config, w);
  const nn::GsmOutputs got = gsm.forward(in);
  const nn::GsmOutputs want = nn::gsm_forward_reference(model.config, w, in, nullptr);
  CHECK(got.elements[0].voxel.count() > 0);
  CHECK(got.elements[0].pixel.count() > 0);
  test::check_gsm_outputs(got, want, 1e-4);
}
