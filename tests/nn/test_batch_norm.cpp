// Inference BatchNorm on the GPU (kernels/nn/batch_norm.h, shaders/nn/batch_norm.comp)
// against the CPU reference (nn::cpu::batch_norm, then ReLU or nn::cpu::silu):
// no activation, fused ReLU and SiLU; odd channel counts and spatial sizes,
// 2-D / 3-D / no spatial axes, batch 3, tiny variances, extreme values (the
// SiLU's exp overflowing), in place (x and y the same buffer), and flat windows
// under a capped binding that cut channels at unaligned offsets. Bound per
// element: 1e-6 + 1e-6 (|x scale| + |shift|) (the float32 scale, shift and fma
// against the double reference). batch_norm_affine on known values. Then the
// official gsm_small conv encoder: stage 0's BN+ReLU (enc.conv.project_head.0)
// and stage 2's BN+SiLU residual block (enc.conv.project_head.2) with the GPU
// BatchNorm and CPU convolutions. Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "kernels/nn/batch_norm.h"
#include "kernels/nn/conv2d.h"
#include "kernels/nn/elementwise.h"
#include "nn/gsm/conv_encoder_reference.h"
#include "nn/gsm/gsm_inputs.h"
#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

using namespace icube;
using kernels::nn::BatchNormActivation;
using kernels::nn::BatchNormShape;

namespace {

nn::CpuTensor uniform_tensor(std::vector<int64_t> shape, uint32_t seed, float lo, float hi) {
  nn::CpuTensor t(std::move(shape));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  for (float& v : t.data) v = u(rng);
  return t;
}

struct BnParams {
  nn::CpuTensor weight, bias, mean, var;
};

BnParams random_params(int64_t C, uint32_t seed, float var_lo = 0.05f) {
  return {uniform_tensor({C}, seed, -2.0f, 2.0f), uniform_tensor({C}, seed + 1, -1.0f, 1.0f),
          uniform_tensor({C}, seed + 2, -1.5f, 1.5f), uniform_tensor({C}, seed + 3, var_lo, 3.0f)};
}

nn::CpuTensor activate(nn::CpuTensor y, BatchNormActivation act) {
  if (act == BatchNormActivation::relu)
    for (float& v : y.data) v = std::max(v, 0.0f);
  if (act == BatchNormActivation::silu) y = nn::cpu::silu(std::move(y));
  return y;
}

// x [B, C, ...]: GPU result with `act`, in place or into a second buffer.
std::vector<float> run_gpu(const nn::CpuTensor& x, const kernels::nn::BatchNormAffine& a, BatchNormActivation act,
                           bool in_place, uint64_t max_binding_bytes = 0) {
  gpu::Context& ctx = test::gpu_context();
  const BatchNormShape s{static_cast<uint32_t>(x.dim(0)), static_cast<uint32_t>(x.dim(1)),
                         static_cast<uint64_t>(x.numel() / (x.dim(0) * x.dim(1)))};
  gpu::Buffer xb = gpu::upload_vector(ctx, x.data, "batch-norm-x");
  gpu::Buffer scale = gpu::upload_vector(ctx, a.scale, "batch-norm-scale");
  gpu::Buffer shift = gpu::upload_vector(ctx, a.shift, "batch-norm-shift");
  gpu::Buffer yb(ctx, x.data.size() * 4, gpu::MemoryUsage::DeviceLocal, "batch-norm-y");
  kernels::nn::BatchNorm bn(ctx);
  bn.set_max_binding_bytes(max_binding_bytes);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { bn.record(cmd, s, xb, scale, shift, in_place ? xb : yb, act); });
  return gpu::download_vector<float>(ctx, in_place ? xb : yb, x.data.size());
}

// Returns the worst err / tol.
double check_batch_norm(const nn::CpuTensor& x, const BnParams& p, BatchNormActivation act, bool in_place,
                        uint64_t max_binding_bytes = 0, double eps = 1e-5) {
  CAPTURE(x.shape_text());
  CAPTURE(static_cast<int>(act));
  CAPTURE(in_place);
  CAPTURE(max_binding_bytes);
  const nn::CpuTensor want = activate(nn::cpu::batch_norm(x, p.weight, p.bias, p.mean, p.var, eps), act);
  const kernels::nn::BatchNormAffine a = kernels::nn::batch_norm_affine(p.weight.data, p.bias.data, p.mean.data, p.var.data, eps);
  const std::vector<float> got = run_gpu(x, a, act, in_place, max_binding_bytes);
  const int64_t C = x.dim(1), S = x.numel() / (x.dim(0) * C);
  size_t bad = 0;
  double worst = 0.0;
  for (size_t i = 0; i < got.size(); ++i) {
    const size_t c = static_cast<size_t>(static_cast<int64_t>(i) / S % C);
    const double bound = std::abs(static_cast<double>(x.data[i]) * static_cast<double>(a.scale[c])) + std::abs(static_cast<double>(a.shift[c]));
    const double tol = 1e-6 + 1e-6 * bound;
    const double err = std::abs(static_cast<double>(got[i]) - static_cast<double>(want.data[i]));
    worst = std::max(worst, err / tol);
    if (!(err <= tol) && ++bad <= 5)
      std::printf("  batch_norm mismatch at %zu: got %.9g want %.9g (tol %.3g)\n", i, static_cast<double>(got[i]),
                  static_cast<double>(want.data[i]), tol);
  }
  CHECK(bad == 0);
  return worst;
}

}  // namespace

TEST_CASE("batch_norm gpu: affine, ReLU and SiLU against the CPU reference, in place, extreme values") {
  double worst = 0.0;
  uint32_t seed = 1;
  for (const BatchNormActivation act : {BatchNormActivation::none, BatchNormActivation::relu, BatchNormActivation::silu}) {
    seed += 100;
    for (const bool in_place : {false, true})
      worst = std::max(worst, check_batch_norm(uniform_tensor({3, 5, 7, 9}, seed + (in_place ? 1u : 0u), -3.0f, 3.0f), random_params(5, seed + 10), act, in_place));
    worst = std::max(worst, check_batch_norm(uniform_tensor({2, 11, 3, 4, 5}, seed + 20, -3.0f, 3.0f), random_params(11, seed + 30), act, false));
    worst = std::max(worst, check_batch_norm(uniform_tensor({4, 13}, seed + 40, -3.0f, 3.0f), random_params(13, seed + 50), act, false));
    // Variances down to 0 (eps alone under the sqrt) and large activations: SiLU's e^-v overflows to
    // infinity for v << 0 (giving -0) and vanishes for v >> 0.
    worst = std::max(worst, check_batch_norm(uniform_tensor({1, 6, 5, 3}, seed + 60, -1e4f, 1e4f), random_params(6, seed + 70, 0.0f), act, true));
    worst = std::max(worst, check_batch_norm(uniform_tensor({1, 3, 4, 4}, seed + 80, -1e30f, 1e30f), random_params(3, seed + 90), act, false));
  }
  MESSAGE("batch_norm: worst |gpu - cpu| / bound = " << worst);
}

TEST_CASE("batch_norm gpu: flat windows under a capped binding") {
  const uint64_t align = std::max<uint64_t>({4, test::gpu_context().info().min_storage_buffer_offset_alignment,
                                             test::gpu_context().info().min_texel_buffer_offset_alignment});
  double worst = 0.0;
  // 37 elements a window over 2 x 5 x 63: windows cut channels and batch elements at unaligned offsets.
  for (const BatchNormActivation act : {BatchNormActivation::relu, BatchNormActivation::silu})
    for (const bool in_place : {false, true})
      worst = std::max(worst, check_batch_norm(uniform_tensor({2, 5, 7, 9}, 301, -3.0f, 3.0f), random_params(5, 302), act, in_place,
                                               37 * 4 + align));
  // Windows of 23 elements over channels of 6: several channels a window.
  worst = std::max(worst, check_batch_norm(uniform_tensor({3, 7, 2, 3}, 303, -3.0f, 3.0f), random_params(7, 304),
                                           BatchNormActivation::none, false, 23 * 4 + align));
  MESSAGE("batch_norm windows: worst |gpu - cpu| / bound = " << worst);

  gpu::Context& ctx = test::gpu_context();
  gpu::Buffer small(ctx, 16 * 4);
  kernels::nn::BatchNorm bn(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(bn.record(cmd, BatchNormShape{1, 4, 8}, small, small, small, small), doctest::Contains("input buffer holds 64 bytes, needs 128"),
                         std::invalid_argument);
  });
  CHECK_THROWS_WITH_AS(kernels::nn::batch_norm_affine({1, 2}, {1, 2}, {1}, {1, 2}), doctest::Contains("differ in length"),
                       std::invalid_argument);
}

TEST_CASE("batch_norm gpu: batch_norm_affine folds the statistics in double") {
  const kernels::nn::BatchNormAffine a = kernels::nn::batch_norm_affine({2.0f, -1.0f}, {0.5f, 3.0f}, {1.0f, -2.0f}, {3.0f, 0.0f}, 1.0);
  // scale = w / sqrt(var + eps): 2 / 2 = 1, -1 / 1 = -1; shift = b - mean scale: 0.5 - 1 = -0.5, 3 - 2 = 1.
  CHECK(a.scale == std::vector<float>{1.0f, -1.0f});
  CHECK(a.shift == std::vector<float>{-0.5f, 1.0f});
}

TEST_CASE("batch_norm gpu: the official gsm_small conv encoder's BN+ReLU and BN+SiLU stages") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::ConvEncoderConfig cfg =
      nn::conv_encoder_config_from_json(nlohmann::json::parse(scene::read_file(dir + "config.json")).at("hparams"));
  REQUIRE(cfg.filters.size() >= 4);
  REQUIRE_FALSE(cfg.residual[0]);
  REQUIRE(cfg.residual[2]);
  REQUIRE_FALSE(cfg.group_norm[2]);
  REQUIRE(cfg.strides[2] == 1);
  const nn::GsmWeights w = nn::load_gsm_weights(dir + "weights.safetensors");
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const std::string head = "img_encoder.encoders.conv.project_head.";
  auto bn_act = [&](const nn::CpuTensor& x, const std::string& p, BatchNormActivation act) {
    const kernels::nn::BatchNormAffine a = kernels::nn::batch_norm_affine(
        w.at(p + "weight").data, w.at(p + "bias").data, w.at(p + "running_mean").data, w.at(p + "running_var").data, 1e-5);
    return nn::CpuTensor(x.shape, run_gpu(x, a, act, true));
  };

  // Stage 0: conv (CPU) -> BatchNorm + ReLU (GPU, in place).
  const nn::CpuTensor images = nn::gsm_images_nchw(nn::read_gsm_inputs(dir + "inputs"));
  const nn::CpuTensor conv0 = nn::cpu::conv2d(images, w.at(head + "0.0.weight"), &w.at(head + "0.0.bias"), cfg.strides[0], cfg.paddings[0]);
  test::check_gsm_tensor(ref, "enc.conv.project_head.0", bn_act(conv0, head + "0.1.", BatchNormActivation::relu));

  // Stage 2 from the reference's stage 1: h = conv3x3(SiLU(BN(x))) twice (BN + SiLU on the GPU), y = x + h.
  const std::string p = head + "2.";
  REQUIRE_FALSE(w.has(p + "skip_connection.weight"));
  const nn::CpuTensor x = ref.get("enc.conv.project_head.1");
  nn::CpuTensor h = bn_act(x, p + "in_layers.0.", BatchNormActivation::silu);
  h = nn::cpu::conv2d(h, w.at(p + "in_layers.2.weight"), &w.at(p + "in_layers.2.bias"), 1, 1);
  h = bn_act(h, p + "out_layers.0.", BatchNormActivation::silu);
  h = nn::cpu::conv2d(h, w.at(p + "out_layers.3.weight"), &w.at(p + "out_layers.3.bias"), 1, 1);
  test::check_gsm_tensor(ref, "enc.conv.project_head.2", nn::cpu::add(x, h));
}
