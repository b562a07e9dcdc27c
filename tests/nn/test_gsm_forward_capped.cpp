// The whole GSM on the GPU (nn/gsm/gsm_gpu.h) with every storage binding
// capped at 1.75 MiB (test::capped_gpu_context): above one view's largest
// tensor of gsm_small at 96 x 160 (its pixel Gaussians, 1.7 MB), below what
// grows with the views and the voxels, which then go through their kernels'
// windows, as the released widths at the released input size do on lavapipe
// (128 MiB bindings: 4 key frames of 64-channel 480 x 832 feature maps are 390
// MiB): on gsm_small's inputs and on a batch of two two-view elements, against
// the CPU reference (every output within 1e-4 of its std, integers and counts
// equal). Runs under the validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gsm_case.h"
#include "nn/gsm/gsm_gpu.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_reference.h"

#include <string>

using namespace icube;

constexpr uint64_t kCap = 1792u << 10;

TEST_CASE("gsm gpu: with storage bindings capped at 1.75 MiB the forward equals the CPU reference" *
          doctest::test_suite("slow-gpu")) {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::capped_gpu_context(kCap);
  const nn::GsmModelConfig model = nn::load_gsm_model_config(dir + "config.json");
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors", model, true);
  nn::GsmGpu gsm(ctx, model.config, w);

  SUBCASE("gsm_small's inputs") {
    const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
    test::check_gsm_outputs(gsm.forward(in), nn::gsm_forward_reference(model.config, w, in, nullptr), 1e-4);
  }
  SUBCASE("a batch of two two-view elements") {
    const nn::GsmInputs in = test::gsm_two_view_batch(dir);
    test::check_gsm_outputs(gsm.forward(in), nn::gsm_forward_reference(model.config, w, in, nullptr), 1e-4);
  }
}
