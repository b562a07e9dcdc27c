// The GSM's GPU stages (engine/nn/gsm/*_gpu.h, through the LayerRecorder) on the
// official gsm_small case: each stage's outputs within 1e-4 of the official
// intermediates' std, as the CPU reference is. Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "nn/gsm/conv_encoder_gpu.h"
#include "nn/gsm/gsm_gpu_weights.h"
#include "nn/gsm/gsm_reference.h"
#include "nn/parameter_store.h"

#include <string>

using namespace icube;

namespace {

nn::CpuTensor download(gpu::Context& ctx, const nn::DeviceTensor& t) {
  return nn::CpuTensor(t.shape, gpu::download_vector<float>(ctx, *t.buf, t.numel()));
}

struct GsmGpuCase {
  std::string dir;
  nn::GsmConfig config;
  nn::GsmInputs inputs;
  nn::GsmGpuWeights weights;
  std::unique_ptr<nn::ParameterStore> store;

  explicit GsmGpuCase(const std::string& d)
      : dir(d), config(nn::read_gsm_config(d + "config.json")), inputs(nn::read_gsm_inputs(d + "inputs")),
        weights(nn::gsm_gpu_weights(nn::load_gsm_weights(d + "weights.safetensors"))) {
    store = std::make_unique<nn::ParameterStore>(test::gpu_context(), weights.specs, weights.tensors,
                                                 nn::ParameterStoreOptions{.network = "the GSM", .source = d + "weights.safetensors", .host_only = weights.host_only});
  }
};

}  // namespace

TEST_CASE("gsm gpu: the conv image encoder matches enc.conv.*") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::gpu_context();
  GsmGpuCase g(dir);
  nn::check_conv_encoder_gpu(g.config.conv, g.config.source);
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  nn::LayerRecorder L(ctx, *g.store, "gsm-test");
  const nn::CpuTensor images = nn::gsm_images_nchw(g.inputs);
  const nn::DeviceTensor x{std::make_shared<gpu::Buffer>(gpu::upload_vector(ctx, images.data, "gsm-images")), images.shape};
  nn::DeviceTensor y;
  std::vector<nn::DeviceTensor> stages;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    y = nn::conv_encoder_gpu(L, g.config.conv, x, &stages);
    L.end();
  });
  REQUIRE(stages.size() == 3);
  for (size_t i = 0; i < stages.size(); ++i) test::check_gsm_tensor(ref, "enc.conv.project_head." + std::to_string(i), download(ctx, stages[i]));
  nn::CpuTensor out = download(ctx, y);
  out.shape = {1, 1, out.dim(1), out.dim(2), out.dim(3)};
  test::check_gsm_tensor(ref, "enc.conv.out", out);
}
