// The GSM's sky token on the GPU (engine/nn/gsm/sky_token_gpu.h: the patch embedding and the post-norm
// transformer through the network layer — LayerRecorder::conv2d, conv, attention_qkv, layer_norm, gelu,
// add — the used patches' gather on the host) against the official tensors of gsm_small
// (sky.patch_embed, sky.tokens_in.b0, sky.tokens_out.b0) and against the CPU reference (sky_tokens,
// sky_reference.h) on the two-view batch of two, on views where every patch is sky (the most tokens),
// where none is (the query alone), and with other widths (embed 24, 3 heads, 2 layers, feed-forward 40;
// seeded random weights). Bound: max |gpu - ref| / std(ref) <= 1e-4 per tensor. Runs under the
// validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "nn/gsm/gsm_gpu_weights.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_random_weights.h"
#include "nn/gsm/sky_reference.h"
#include "nn/gsm/sky_token_gpu.h"
#include "nn/layer_recorder.h"
#include "nn/parameter_store.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <memory>

using namespace icube;

namespace {

// The sky tokens of `in` on the GPU and on the CPU reference, both traced.
struct SkyRun {
  nn::CpuTensor gpu, cpu;
  nn::GsmTrace gpu_trace, cpu_trace;
};

SkyRun run_both(const nn::SkyConfig& c, const nn::GsmWeights& w, const nn::GsmInputs& in) {
  gpu::Context& ctx = test::gpu_context();
  const nn::GsmGpuWeights g = nn::gsm_gpu_weights(w);
  nn::ParameterStoreOptions o;
  o.network = "the GSM";
  o.host_only = g.host_only;
  const nn::ParameterStore store(ctx, g.specs, g.tensors, o);
  nn::LayerRecorder L(ctx, store, "sky-test");
  const nn::CpuTensor images = nn::gsm_images_nchw(in);
  const nn::DeviceTensor dev{std::make_shared<gpu::Buffer>(gpu::upload_vector(ctx, images.data, "sky-test-images")), images.shape};
  SkyRun r;
  r.gpu = nn::sky_tokens_gpu(L, c, w, in, dev, &r.gpu_trace);
  r.cpu = nn::sky_tokens(c, w, in, images, &r.cpu_trace);
  return r;
}

void check_against_cpu(const SkyRun& r, const char* what) {
  const double e = nn::cpu::max_abs_over_std(r.gpu.data, r.cpu.data);
  std::printf("sky token gpu %s: tokens %.3g of std", what, e);
  CHECK(r.gpu.shape == r.cpu.shape);
  CHECK(e <= 1e-4);
  for (const auto& [name, t] : r.cpu_trace.tensors) {
    if (name.rfind("sky.tokens_out", 0) != 0) continue;
    const nn::CpuTensor& got = r.gpu_trace.tensors.at(name);
    REQUIRE(got.shape == t.shape);
    const double et = nn::cpu::max_abs_over_std(got.data, t.data);
    std::printf(", %s [%lld tokens] %.3g", name.c_str(), static_cast<long long>(t.dim(0)), et);
    CHECK(et <= 1e-4);
  }
  std::printf("\n");
}

// Every view all sky (mask ch0 = 0) or none.
nn::GsmInputs with_sky(nn::GsmInputs in, bool sky) {
  for (size_t p = 0; p < in.masks.size(); p += 4) in.masks[p] = sky ? 0 : 1;
  return in;
}

}  // namespace

TEST_CASE("gsm sky token gpu: gsm_small's tensors and the CPU reference on batches, all-sky and no-sky views") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmModelConfig model = nn::load_gsm_model_config(dir + "config.json");
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors", model, true);
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const SkyRun r = run_both(model.config.sky, w, in);
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  for (const char* name : {"sky.patch_embed", "sky.tokens_in.b0", "sky.tokens_out.b0"})
    CHECK(test::check_gsm_tensor(ref, name, r.gpu_trace.tensors.at(name)));
  check_against_cpu(r, "gsm_small");
  check_against_cpu(run_both(model.config.sky, w, test::gsm_two_view_batch(dir)), "two-view batch of two");
  const SkyRun all = run_both(model.config.sky, w, with_sky(test::gsm_two_view_batch(dir), true));
  check_against_cpu(all, "all sky");
  const SkyRun none = run_both(model.config.sky, w, with_sky(in, false));
  CHECK(none.gpu_trace.tensors.at("sky.tokens_out.b0").dim(0) == 1);  // the query alone
  check_against_cpu(none, "no sky");
}

TEST_CASE("gsm sky token gpu: other widths (embed 24, 3 heads, 2 layers) equal the CPU reference") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  std::ifstream f(dir + "config.json");
  nlohmann::json j = nlohmann::json::parse(f);
  nlohmann::json& m = j["hparams"]["skybox_mlp_modulator"];
  m["embed_dim"] = 24;
  m["num_heads"] = 3;
  m["transformer"]["num_layers"] = 2;
  m["transformer"]["dim_feedforward"] = 40;
  const nn::GsmModelConfig model = nn::gsm_model_config_from_json(j, "sky test config");
  REQUIRE(model.config.sky.embed_dim == 24);
  const nn::GsmWeights w = nn::gsm_random_weights(nn::gsm_param_specs(model), 91u);
  check_against_cpu(run_both(model.config.sky, w, test::gsm_two_view_batch(dir)), "embed 24, 3 heads");
}
