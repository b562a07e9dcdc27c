// The whole GSM on the GPU (nn/gsm/gsm_gpu.h) with every storage binding
// capped at 64 KiB (test::capped_gpu_context), so that every tensor larger
// than one binding goes through its kernel's windows, as the released widths
// at the released input size do on lavapipe (128 MiB bindings: 4 key frames of
// 64-channel 480 x 832 feature maps are 390 MiB): on gsm_small's inputs and on
// a batch of two two-view elements, against the CPU reference (every output
// within 1e-4 of its std, integers and counts equal). Runs under the
// validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gsm_case.h"
#include "nn/gsm/gsm_gpu.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_reference.h"

#include <cstring>
#include <string>

using namespace icube;

namespace {

constexpr uint64_t kCap = 1792u << 10;

void check_against_reference(const nn::GsmOutputs& got, const nn::GsmOutputs& want) {
  const std::vector<nn::TensorToWrite> g = nn::gsm_output_tensors(got), w = nn::gsm_output_tensors(want);
  REQUIRE(g.size() == w.size());
  for (size_t i = 0; i < g.size(); ++i) {
    CAPTURE(g[i].name);
    REQUIRE(g[i].name == w[i].name);
    REQUIRE(g[i].shape == w[i].shape);
    if (g[i].dtype != nn::DType::F32) {
      CHECK(g[i].bytes == w[i].bytes);
      continue;
    }
    std::vector<float> a(g[i].bytes.size() / 4), b(w[i].bytes.size() / 4);
    std::memcpy(a.data(), g[i].bytes.data(), g[i].bytes.size());
    std::memcpy(b.data(), w[i].bytes.data(), w[i].bytes.size());
    if (a.empty()) continue;
    const double e = nn::cpu::max_abs_over_std(a, b);
    CHECK_MESSAGE(e <= 1e-4, g[i].name << ": " << e << " of std against the CPU reference");
  }
}

}  // namespace

TEST_CASE("gsm gpu: with storage bindings capped at 64 KiB the forward equals the CPU reference" *
          doctest::test_suite("slow-gpu")) {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  gpu::Context& ctx = test::capped_gpu_context(kCap);
  const nn::GsmModelConfig model = nn::load_gsm_model_config(dir + "config.json");
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors", model, true);
  nn::GsmGpu gsm(ctx, model.config, w);

  SUBCASE("gsm_small's inputs") {
    const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
    check_against_reference(gsm.forward(in), nn::gsm_forward_reference(model.config, w, in, nullptr));
  }
  SUBCASE("a batch of two two-view elements") {
    const nn::GsmInputs in = test::gsm_two_view_batch(dir);
    check_against_reference(gsm.forward(in), nn::gsm_forward_reference(model.config, w, in, nullptr));
  }
}
