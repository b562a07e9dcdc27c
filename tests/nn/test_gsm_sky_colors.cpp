// The GSM's sky colours on the GPU (kernels/nn/gsm_sky_colors.h,
// shaders/nn/gsm_sky_colors.comp) against the double CPU reference
// (nn::cpu::gsm_sky_colors) and against the model's CPU sky (engine/nn/gsm/
// sky_reference.h: sky_colors, the official module's layer by layer): the
// released widths (192 hidden, 3 colours) and odd ones (37 hidden, 1 and 4
// outputs), two batch elements with their own modulation, random unit
// directions plus the axes, a zero direction (the LayerNorm of the bias
// alone) and huge weights; windows of rows with storage bindings capped at
// 4 KiB. Bound: atol 1e-5 + rtol 1e-5 (float32 sums over the hidden units).
// Runs under the validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu_test_context.h"
#include "kernels/nn/gsm_sky_colors.h"
#include "nn/gsm/sky_reference.h"

#include <cmath>
#include <cstdio>
#include <random>

using namespace icube;

namespace {

struct SkyCase {
  uint32_t hidden = 0, out = 0, element_rows = 0;
  std::vector<float> pos_w, pos_b, out_w, out_b, modulation, dirs;
};

SkyCase make_case(uint32_t hidden, uint32_t out, uint32_t rows_per_element, uint32_t seed, float weight_scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  SkyCase c;
  c.hidden = hidden;
  c.out = out;
  c.element_rows = rows_per_element;
  auto fill = [&](std::vector<float>& v, size_t n, float scale) {
    v.resize(n);
    for (float& x : v) x = scale * u(rng);
  };
  fill(c.pos_w, 3 * hidden, weight_scale);
  fill(c.pos_b, hidden, 0.5f);
  fill(c.out_w, size_t{out} * hidden, 0.2f);
  fill(c.out_b, out, 0.5f);
  fill(c.modulation, 2 * 2 * size_t{hidden}, 0.7f);  // two elements
  for (uint32_t r = 0; r < 2 * rows_per_element; ++r) {
    float d[3] = {u(rng), u(rng), u(rng)};
    if (r < 6) {  // the axes, both signs
      d[0] = d[1] = d[2] = 0.0f;
      d[r / 2] = r % 2 ? -1.0f : 1.0f;
    } else if (r == 6) {
      d[0] = d[1] = d[2] = 0.0f;  // the bias alone
    }
    const float n = r == 6 ? 1.0f : std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (float x : d) c.dirs.push_back(x / n);
  }
  return c;
}

std::vector<float> run_gpu(gpu::Context& ctx, const SkyCase& c, size_t& dispatches) {
  const std::vector<float> mlp = kernels::nn::pack_gsm_sky_mlp(c.pos_w, c.pos_b, c.out_w, c.out_b);
  gpu::Buffer dirs = gpu::upload_vector(ctx, c.dirs, "sky-dirs");
  gpu::Buffer weights = gpu::upload_vector(ctx, mlp, "sky-mlp");
  gpu::Buffer modulation = gpu::upload_vector(ctx, c.modulation, "sky-modulation");
  const size_t rows = c.dirs.size() / 3;
  gpu::Buffer y(ctx, rows * c.out * 4, gpu::MemoryUsage::DeviceLocal, "sky-colours");
  kernels::nn::GsmSkyColors k(ctx);
  kernels::nn::GsmSkyColorsShape s;
  s.rows = static_cast<uint32_t>(rows);
  s.hidden = c.hidden;
  s.out_channels = c.out;
  s.element_rows = c.element_rows;
  s.elements = 2;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { k.record(cmd, s, dirs, weights, modulation, y); });
  dispatches = k.last_dispatches();
  return gpu::download_vector<float>(ctx, y, rows * c.out);
}

// Checks |gpu - ref| <= atol + rtol |ref|, printing the first mismatches; returns the worst |gpu - ref|.
double check_close(const std::vector<float>& got, const std::vector<float>& want, double atol, double rtol) {
  REQUIRE(got.size() == want.size());
  double worst = 0.0;
  int printed = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    const double e = std::fabs(double(got[i]) - double(want[i]));
    worst = std::max(worst, e);
    if (!(e <= atol + rtol * std::fabs(double(want[i]))) && printed++ < 5)
      std::printf("  mismatch at %zu: gpu %.9g, reference %.9g\n", i, double(got[i]), double(want[i]));
  }
  CHECK(printed == 0);
  return worst;
}

}  // namespace

TEST_CASE("gsm_sky_colors gpu: the sky MLP matches the CPU reference and the model's sky") {
  gpu::Context& ctx = test::gpu_context();
  for (const auto& [hidden, out, rows, scale] : {std::tuple{192u, 3u, 517u, 1.0f}, {37u, 1u, 101u, 1.0f}, {37u, 4u, 64u, 1e4f}}) {
    CAPTURE(hidden);
    CAPTURE(out);
    CAPTURE(scale);
    const SkyCase c = make_case(hidden, out, rows, 7u + hidden + out, scale);
    const std::vector<float> mlp = kernels::nn::pack_gsm_sky_mlp(c.pos_w, c.pos_b, c.out_w, c.out_b);
    const std::vector<float> want = nn::cpu::gsm_sky_colors(c.dirs, mlp, c.modulation, hidden, out, rows, 0);
    size_t dispatches = 0;
    const double worst = check_close(run_gpu(ctx, c, dispatches), want, 1e-5, 1e-5);
    CHECK(dispatches == 1);
    MESSAGE("worst |gpu - cpu| = " << worst);
  }
}

TEST_CASE("gsm_sky_colors: the kernel's reference is the model's sky_colors under a token") {
  // The model's CPU sky (cpu::linear, cpu::layer_norm, the adaLN modulation from the token) on random weights:
  // the kernel's reference with the modulation computed from the same token agrees to float rounding.
  nn::SkyConfig sc;
  sc.embed_dim = 8;
  sc.hidden_channels = 24;
  sc.out_channels = 3;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  nn::GsmWeights w;
  auto linear = [&](const std::string& name, int64_t o, int64_t i) {
    nn::CpuTensor W({o, i}), b({o});
    for (float& x : W.data) x = 0.5f * u(rng);
    for (float& x : b.data) x = 0.3f * u(rng);
    w.tensors["skybox.modulator." + name + ".weight"] = W;
    w.tensors["skybox.modulator." + name + ".bias"] = b;
  };
  linear("pos_emb", 24, 3);
  linear("adaLN_modulation.1", 48, 24);
  linear("condition_mapping", 24, 8);
  linear("output", 3, 24);
  std::vector<float> token(8);
  for (float& x : token) x = u(rng);
  nn::CpuTensor dirs({50, 3});
  for (int64_t r = 0; r < 50; ++r) {
    float d[3] = {u(rng), u(rng), u(rng)};
    const float n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; ++a) dirs.data[size_t(3 * r + a)] = d[a] / n;
  }
  const nn::CpuTensor model = nn::sky_colors(sc, w, token.data(), dirs);
  const std::vector<float> modulation = nn::sky_modulation(sc, w, token.data());
  REQUIRE(modulation.size() == 48);
  const std::vector<float> mlp =
      kernels::nn::pack_gsm_sky_mlp(w.at("skybox.modulator.pos_emb.weight").data, w.at("skybox.modulator.pos_emb.bias").data,
                                    w.at("skybox.modulator.output.weight").data, w.at("skybox.modulator.output.bias").data);
  check_close(nn::cpu::gsm_sky_colors(dirs.data, mlp, modulation, 24, 3, 50, 0), model.data, 1e-6, 1e-5);
}

TEST_CASE("gsm_sky_colors gpu: directions past one storage binding go in windows of rows") {
  // 4 KiB bindings (~1,000 floats): 2 x 700 directions of 3 (and 4 colours) go in windows of ~250 rows, the
  // second element's rows straddling windows.
  gpu::Context& capped = test::capped_gpu_context(4u << 10);
  const SkyCase c = make_case(37, 4, 700, 23, 1.0f);
  const std::vector<float> mlp = kernels::nn::pack_gsm_sky_mlp(c.pos_w, c.pos_b, c.out_w, c.out_b);
  size_t dispatches = 0;
  check_close(run_gpu(capped, c, dispatches), nn::cpu::gsm_sky_colors(c.dirs, mlp, c.modulation, 37, 4, 700, 0), 1e-5, 1e-5);
  CHECK(dispatches >= 5);
}
