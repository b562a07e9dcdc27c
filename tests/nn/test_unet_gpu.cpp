// The dense diffusion UNet on the GPU (engine/nn/unet_gpu.h) against the
// official PyTorch module's reference case (unet_small: output and every block
// within max |y - y_ref| / std(y_ref) <= 1e-4) and against the CPU reference on
// a second configuration (batch 2, a non-cubic grid, a 2-block transformer with
// its first self-attention on); fp16 weights (exact on the rounded weights) and fp16
// precision (weights and convolution operands: within fp16's bound of fp32, in one
// binding and in windows, through the transformer's LayerNorms); the layer
// recorder's refusal of fp16 tensors outside the convolutions. Validation on.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "half_values.h"
#include "kernels/nn/conv3d.h"
#include "nn/scoped_kernel_family.h"
#include "nn/unet_case_check.h"
#include "kernels/nn/cpu_tensor.h"
#include "nn/layer_recorder.h"
#include "nn/parameter_store.h"
#include "nn/safetensors.h"
#include "nn/unet_config.h"
#include "nn/unet_gpu.h"
#include "nn/unet_reference.h"
#include "nn/weights.h"
#include "world/npy.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>

using namespace icube;

namespace {

// The second configuration: a non-cubic grid, resampling ResBlocks, a 2-block transformer with its first
// self-attention on.
nn::UNetConfig second_config() {
  return nn::parse_unet_config(R"({"image_size": 8, "num_input_channels": 5, "out_channels": 3,
    "model_channels": 32, "num_res_blocks": 1, "attention_resolutions": [2], "channel_mult": [1, 2], "num_heads": 4,
    "use_scale_shift_norm": true, "resblock_updown": true, "transformer_depth": 2,
    "middile_force_spatial_transformer": true, "middle_disable_first_sa": false})",
                               "second.json");
}

// N(0, 0.2^2) values for every parameter of `ref`, drawn from `rng` in parameter order.
std::map<std::string, nn::CpuTensor> normal_weights(const nn::UNetReference& ref, std::mt19937& rng) {
  std::normal_distribution<float> nd(0.0f, 0.2f);
  std::map<std::string, nn::CpuTensor> w;
  for (const nn::ParamSpec& p : ref.parameters()) {
    nn::CpuTensor t(p.shape);
    for (float& f : t.data) f = nd(rng);
    w.emplace(p.name, std::move(t));
  }
  return w;
}

// The second configuration with N(0, 0.2^2) weights (set on its CPU reference) and a batch-2 input of
// N(0, 1) values, all drawn from one seed.
struct SecondCase {
  nn::UNetConfig cfg = second_config();
  nn::UNetReference ref{cfg};
  std::map<std::string, nn::CpuTensor> w;
  nn::CpuTensor x{std::vector<int64_t>{2, 5, 6, 2, 4}};
  explicit SecondCase(uint32_t seed) {
    std::mt19937 rng(seed);
    w = normal_weights(ref, rng);
    ref.set_weights(w);
    std::normal_distribution<float> nd(0.0f, 0.2f);
    for (float& f : x.data) f = nd(rng) * 5.0f;
  }
};

}  // namespace

// The official unet_small case through UNetGpu, output and every block within 1e-4 of std; `family` runs it
// with that kernel family (kernels/nn/kernel_family.h), nullptr with the device's own.
static void check_unet_small(const char* family) {
  const std::string cfg_path = test::test_data_file("models/unet_small/config.json");
  if (cfg_path.empty()) return;
  std::optional<test::ScopedKernelFamily> scoped;
  if (family) scoped.emplace(family);
  const std::string m = cfg_path.substr(0, cfg_path.size() - std::string("config.json").size());
  const nn::UNetConfig cfg = nn::load_unet_config(cfg_path);
  const nn::UNetReference spec(cfg);
  const nn::SafetensorsFile weights(m + "weights.safetensors");
  nn::UNetGpu net(test::gpu_context(), cfg, nn::load_weights_cpu(weights, spec.parameters(), {}));
  const test::UNetCaseResult r = test::check_unet_small_case(
      m, [&](const nn::CpuTensor& x, const std::vector<int64_t>& t, const nn::UNetReference::Capture& c) {
        return net.forward(x, t, c);
      });
  MESSAGE("unet gpu, unet_small (" << std::string(family ? family : "the device's") << " kernels): output max |y - y_ref| / std = "
                                   << r.output << "; worst of " << r.blocks << " blocks " << r.worst_block
                                   << "; activations " << net.last_activation_bytes() / 1024 << " KiB");
}

TEST_CASE("unet gpu: unet_small matches the official PyTorch module, output and every block") { check_unet_small(nullptr); }

TEST_CASE("unet gpu: unet_small through the GPUs' kernel family (shared-memory conv3d and attention) on the test device") {
  check_unet_small("gpu");
}

TEST_CASE("unet gpu: a second configuration agrees with the CPU reference (batch 2, self-attention middle)") {
  SecondCase c(17);
  nn::UNetGpu gpu_net(test::gpu_context(), c.cfg, c.w);
  const nn::CpuTensor want = c.ref.forward(c.x, {3, 977});
  const nn::CpuTensor got = gpu_net.forward(c.x, {3, 977});
  REQUIRE(got.shape == want.shape);
  const double e = nn::cpu::max_abs_over_std(got.data, want.data);
  MESSAGE("unet gpu vs CPU reference, second configuration: max |y - y_ref| / std = " << e);
  CHECK(e <= 1e-4);
  // Every windowed kernel in windows: as if one binding held 2 KiB (a level's tensor is 6-12 KiB).
  nn::UNetGpu windowed(test::gpu_context(), c.cfg, c.w);
  windowed.set_max_binding_bytes(2048);
  const nn::CpuTensor got_w = windowed.forward(c.x, {3, 977});
  const double ew = nn::cpu::max_abs_over_std(got_w.data, want.data);
  MESSAGE("  the same in 2 KiB windows: " << ew);
  CHECK(ew <= 1e-4);
}

TEST_CASE("unet gpu: fp16 weight storage on unet_small (exact on fp16-rounded weights; its error against fp32)") {
  const std::string cfg_path = test::test_data_file("models/unet_small/config.json");
  if (cfg_path.empty()) return;
  const std::string m = cfg_path.substr(0, cfg_path.size() - std::string("config.json").size());
  const nn::UNetConfig cfg = nn::load_unet_config(cfg_path);
  nn::UNetReference ref(cfg);
  const nn::SafetensorsFile file(m + "weights.safetensors");
  std::map<std::string, nn::CpuTensor> w = nn::load_weights_cpu(file, ref.parameters(), {});
  nn::UNetGpu net(test::gpu_context(), cfg, w, nn::UNetGpu::Precision::F16Weights);
  // The CPU reference on the weights the kernels read: conv / linear weights rounded to fp16.
  for (auto& [name, t] : w)
    if (t.rank() >= 2)
      for (float& v : t.data) v = test::round_to_half(v);
  ref.set_weights(std::move(w));
  const world::NpyArray x = world::read_npy(m + "case_1.x.npy"), t = world::read_npy(m + "case_1.t.npy"),
                        y = world::read_npy(m + "case_1.out.npy");
  const nn::CpuTensor xin(std::vector<int64_t>(x.shape.begin(), x.shape.end()), x.values<float>());
  const nn::CpuTensor got = net.forward(xin, t.values<int64_t>());
  const nn::CpuTensor want = ref.forward(xin, t.values<int64_t>());
  const double exact = nn::cpu::max_abs_over_std(got.data, want.data);
  const double vs_fp32 = nn::cpu::max_abs_over_std(got.data, y.values<float>());
  MESSAGE("unet_small, fp16 weights: vs CPU reference on fp16-rounded weights " << exact << ", vs the official fp32 output "
                                                                                << vs_fp32 << "; weights "
                                                                                << net.weight_bytes() / 1024 << " KiB");
  // With fp16 weights a GPU with cooperative matrices convolves fp16 activations too (conv3d_coopmat):
  // then the kernels are no longer exact on rounded weights alone, and only fp16's bound holds.
  const bool f16_operands = kernels::nn::conv3d_path_rounds_activations(
      kernels::nn::default_conv3d_path(test::gpu_context().info(), true));
  CHECK(exact <= (f16_operands ? 1e-2 : 1e-4));
  CHECK(vs_fp32 <= 1e-2);  // fp16's 11-bit mantissa, measured ~1e-3
  CHECK(vs_fp32 > 1e-6);   // the weights really are rounded
}

TEST_CASE("unet gpu: fp16 precision on unet_small (fp16 weights and fp16 convolution operands; its error against fp32)") {
  const std::string cfg_path = test::test_data_file("models/unet_small/config.json");
  if (cfg_path.empty()) return;
  const std::string m = cfg_path.substr(0, cfg_path.size() - std::string("config.json").size());
  const nn::UNetConfig cfg = nn::load_unet_config(cfg_path);
  const nn::UNetReference spec(cfg);
  const nn::SafetensorsFile file(m + "weights.safetensors");
  const std::map<std::string, nn::CpuTensor> w = nn::load_weights_cpu(file, spec.parameters(), {});
  gpu::Context& ctx = test::gpu_context();
  nn::UNetGpu f16(ctx, cfg, w, nn::UNetGpu::Precision::F16), f16_weights(ctx, cfg, w, nn::UNetGpu::Precision::F16Weights);
  const world::NpyArray x = world::read_npy(m + "case_1.x.npy"), t = world::read_npy(m + "case_1.t.npy"),
                        y = world::read_npy(m + "case_1.out.npy");
  const nn::CpuTensor xin(std::vector<int64_t>(x.shape.begin(), x.shape.end()), x.values<float>());
  size_t captured = 0;  // block outputs stay fp32 and can be captured
  const nn::CpuTensor got = f16.forward(xin, t.values<int64_t>(), [&](const std::string&, const nn::CpuTensor&) { ++captured; });
  const nn::CpuTensor got_w = f16_weights.forward(xin, t.values<int64_t>());
  const double vs_fp32 = nn::cpu::max_abs_over_std(got.data, y.values<float>());
  const double operands = nn::cpu::max_abs_over_std(got.data, got_w.data);
  MESSAGE("unet_small, fp16: vs the official fp32 output " << vs_fp32 << " of std, vs fp16 weights alone " << operands
                                                            << "; activations " << f16.last_activation_bytes() / 1024
                                                            << " KiB against " << f16_weights.last_activation_bytes() / 1024);
  CHECK(captured > 10);
  CHECK(vs_fp32 <= 1e-2);  // fp16's 11-bit mantissa
  // The tensor-core kernels round their operands to fp16 anyway: there fp16 operands change nothing. Elsewhere
  // the rounding is the operands' own.
  if (kernels::nn::conv3d_path_rounds_activations(kernels::nn::default_conv3d_path(ctx.info(), true)))
    CHECK(operands == 0.0);
  else
    CHECK(operands > 1e-7);
  // Windows (128 KiB bindings; the first level's tensors are 384 KiB and more): fp16 norm outputs and
  // convolution inputs in windows of 2-byte elements.
  nn::UNetGpu windowed(ctx, cfg, w, nn::UNetGpu::Precision::F16);
  windowed.set_max_binding_bytes(128u << 10);
  const nn::CpuTensor got_windowed = windowed.forward(xin, t.values<int64_t>());
  // The windows sum in another order (fp32: ~1e-5 of std); a sum that moves by an ulp can move a norm's
  // output across an fp16 rounding boundary, and that flip (~5e-4 relative) propagates: so the bound is
  // fp16's, as against fp32 (a wrong window offset or element size is an O(1) error).
  const double ew = nn::cpu::max_abs_over_std(got_windowed.data, got.data);
  const double ew_fp32 = nn::cpu::max_abs_over_std(got_windowed.data, y.values<float>());
  MESSAGE("  the same in 128 KiB windows: " << ew << " of std from one binding, " << ew_fp32 << " from fp32");
  CHECK(ew <= 1e-2);
  CHECK(ew_fp32 <= 1e-2);
}

TEST_CASE("unet gpu: fp16 precision through a transformer (LayerNorm outputs in fp16) against the fp32 reference") {
  SecondCase c(18);
  nn::UNetGpu gpu_net(test::gpu_context(), c.cfg, c.w, nn::UNetGpu::Precision::F16);
  const double e = nn::cpu::max_abs_over_std(gpu_net.forward(c.x, {3, 977}).data, c.ref.forward(c.x, {3, 977}).data);
  MESSAGE("unet gpu fp16 vs the fp32 CPU reference, second configuration: " << e << " of std");
  CHECK(e <= 2e-2);
  CHECK(e > 1e-6);
}

TEST_CASE("layer recorder: only convolutions take an fp16 tensor; every other layer refuses it") {
  gpu::Context& ctx = test::gpu_context();
  const nn::ParameterStore params(ctx, {}, {}, {});
  nn::LayerRecorder L(ctx, params, "test-activation");
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    const nn::DeviceTensor h = L.alloc({1, 8, 4, 4, 4}, true), f = L.alloc({1, 8, 4, 4, 4});
    CHECK(h.bytes() == 8 * 64 * 2);
    CHECK_THROWS_WITH_AS(L.silu(h), doctest::Contains("silu of an fp16 tensor"), std::logic_error);
    CHECK_THROWS_WITH_AS(L.add(f, h), doctest::Contains("add of an fp16 tensor"), std::logic_error);
    CHECK_THROWS_WITH_AS(L.resample(h, true), doctest::Contains("resample of an fp16 tensor"), std::logic_error);
    CHECK_THROWS_WITH_AS(L.attention_qkv(L.alloc({1, 24, 64}, true), 2), doctest::Contains("attention of an fp16"),
                         std::logic_error);
    L.end();
  });
}

TEST_CASE("layer recorder: counts the multiply-add FLOPs of convolutions, linears and attention") {
  gpu::Context& ctx = test::gpu_context();
  const std::vector<nn::ParamSpec> specs = {{"c.weight", {4, 3, 3, 3, 3}}, {"c.bias", {4}}, {"l.weight", {24, 4}}};
  std::map<std::string, nn::CpuTensor> w;
  for (const nn::ParamSpec& p : specs) w.emplace(p.name, nn::CpuTensor(p.shape, 0.5f));
  const nn::ParameterStore params(ctx, specs, w, {});
  nn::LayerRecorder L(ctx, params, "test-activation");
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    L.begin(cmd);
    const nn::DeviceTensor x = L.alloc({2, 3, 5, 6, 7});
    const nn::DeviceTensor h = L.conv(x, "c");                        // 2 B Co Ci 27 V
    CHECK(L.matmul_flops() == 2ull * 2 * 4 * 3 * 27 * 210);
    const nn::DeviceTensor qkv = L.conv(nn::LayerRecorder::tokens(h), "l");  // a linear 4 -> 24 over 210 tokens
    CHECK(L.matmul_flops() == 2ull * 2 * 4 * 3 * 27 * 210 + 2ull * 2 * 24 * 4 * 210);
    L.reset_matmul_flops();
    L.attention_qkv(qkv, 2);  // Q K^T and P V: 4 B C N^2 with C = 8
    CHECK(L.matmul_flops() == 4ull * 2 * 8 * 210 * 210);
    L.end();
  });
}
