// The GSM pixel branch's Gaussian decoding on the GPU (kernels/nn/gsm_pixel_gaussians.h,
// shaders/nn/gsm_pixel_gaussians.comp) against its CPU reference
// (nn::cpu::gsm_pixel_gaussians): random raw values and masks, random cameras
// (rotations, translations up to 150 m, off-centre principal points), sizes
// 1 x 1, 13 x 7, 9 x 127 and batches of 1 to 3 views (each view a dispatch from
// an unaligned offset), 1 to 3 Gaussians of 10 to 14 values, "weight" and
// inverse depth, with and without the mid-ground rule, extreme values (depth,
// scale and opacity logits of +-1e4, quaternions of 1e-30 and 1e30, a zero
// quaternion). The keep values must be equal; the Gaussians within float32
// rounding of the formulas: means 4e-6 (|t| + distance) plus two ulps of
// |t| + 2 times the distance (the ray's float32 cancellation), scales 1e-5 relative,
// rotations and opacities 2e-6, colours equal. Then gsm_small: the dense CPU
// reference compacted equals the pixel branch's reference decoder
// (decode_pixel_gaussians), and the GPU kernel fed pix.gs_params gives
// gs.b0.pixel.* and pix.gaussian_pixel_mask within 1e-4 of their std. Runs
// under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "kernels/nn/gsm_pixel_gaussians.h"
#include "nn/gsm/gsm_inputs.h"
#include "nn/gsm/pixel_branch_gpu.h"
#include "nn/gsm/pixel_branch_reference.h"
#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

using namespace icube;
using kernels::nn::GsmPixelGaussiansShape;

namespace {

struct DenseResult {
  std::vector<float> gaussians, mask;
};

DenseResult run_gpu(const GsmPixelGaussiansShape& s, const nn::CpuTensor& params, const std::vector<float>& fg,
                    const std::vector<float>& grid, const std::vector<float>& cameras) {
  gpu::Context& ctx = test::gpu_context();
  const uint64_t V = s.views, P = s.pixels(), out = V * P * s.gs_per_pixel * s.record_floats();
  gpu::Buffer pb = gpu::upload_vector(ctx, params.data, "gsm-pix-params");
  gpu::Buffer fb = gpu::upload_vector(ctx, fg, "gsm-pix-fg");
  gpu::Buffer gb = gpu::upload_vector(ctx, grid, "gsm-pix-grid");
  gpu::Buffer cb = gpu::upload_vector(ctx, cameras, "gsm-pix-cameras");
  gpu::Buffer ob(ctx, std::max<uint64_t>(out, 1) * 4, gpu::MemoryUsage::DeviceLocal, "gsm-pix-out");
  gpu::Buffer mb(ctx, std::max<uint64_t>(V * P, 1) * 4, gpu::MemoryUsage::DeviceLocal, "gsm-pix-mask");
  kernels::nn::GsmPixelGaussians op(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { op.record(cmd, s, pb, fb, gb, cb, ob, mb); });
  return {gpu::download_vector<float>(ctx, ob, out), gpu::download_vector<float>(ctx, mb, V * P)};
}

// A random camera-to-grid pose (a rotation from a random unit quaternion, translation up to `reach` m) and
// intrinsics for a W x H image.
std::pair<std::array<float, 16>, std::array<float, 6>> random_camera(std::mt19937& rng, int64_t H, int64_t W, float reach) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double q[4];
  double qn = 0.0;
  for (double& v : q) {
    v = n(rng);
    qn += v * v;
  }
  qn = std::sqrt(qn);
  const double w = q[0] / qn, x = q[1] / qn, y = q[2] / qn, z = q[3] / qn;
  const double R[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                       2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                       2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
  std::array<float, 16> P{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) P[static_cast<size_t>(r * 4 + c)] = static_cast<float>(R[r * 3 + c]);
    P[static_cast<size_t>(r * 4 + 3)] = static_cast<float>(static_cast<double>(reach) * u(rng));
  }
  P[15] = 1.0f;
  const double f = 0.8 * static_cast<double>(std::max(H, W)) * (1.0 + 0.3 * u(rng));
  std::array<float, 6> K = {static_cast<float>(f), static_cast<float>(f * (1.0 + 0.05 * u(rng))),
                            static_cast<float>(0.5 * static_cast<double>(W) + 3.0 * u(rng)),
                            static_cast<float>(0.5 * static_cast<double>(H) + 3.0 * u(rng)), static_cast<float>(W),
                            static_cast<float>(H)};
  return {P, K};
}

// Compares the GPU's dense output with the CPU reference's; returns the worst error / tolerance.
double compare(const GsmPixelGaussiansShape& s, const nn::cpu::GsmPixelGaussiansDense& want, const DenseResult& got,
               const std::vector<float>& cameras) {
  CHECK(test::equal_report(got.mask, want.mask.data, "keep values"));
  const int64_t V = s.views, P = static_cast<int64_t>(s.pixels()), G = s.gs_per_pixel, R = s.record_floats();
  size_t bad = 0;
  double worst = 0.0;
  auto check = [&](double g, double w, double tol, const char* what, int64_t at) {
    const double err = std::abs(g - w);
    const bool ok = err <= tol || (std::isnan(g) && std::isnan(w)) || g == w;
    if (!ok && ++bad <= 8) std::printf("  %s of Gaussian %lld: got %.9g want %.9g (tol %.3g)\n", what, static_cast<long long>(at), g, w, tol);
    if (std::isfinite(err)) worst = std::max(worst, err / tol);
  };
  for (int64_t v = 0; v < V; ++v) {
    const float* t = cameras.data() + v * kernels::nn::gsm_pixel_camera_floats() + 3;
    const double reach = std::max({std::abs(double(t[0])), std::abs(double(t[4])), std::abs(double(t[8]))});
    for (int64_t k = v * P * G; k < (v + 1) * P * G; ++k) {
      const float* g = got.gaussians.data() + k * R;
      const float* w = want.gaussians.data.data() + k * R;
      double distance = 0.0;
      for (int i = 0; i < 3; ++i) distance = std::max(distance, std::abs(double(w[i]) - double(t[4 * i])));
      // The ray's float32 cancellation (P x)[:3] - t may round differently by an ulp of |t| + |d|, then
      // scaled by the distance.
      const double tol = 4e-6 * (reach + distance) + 2.4e-7 * (reach + 2.0) * distance + 1e-30;
      for (int i = 0; i < 3; ++i) check(g[i], w[i], tol, "mean", k);
      for (int i = 3; i < 6; ++i) check(g[i], w[i], 1e-5 * std::abs(double(w[i])) + 1e-37, "scale", k);
      for (int i = 6; i < 11; ++i) check(g[i], w[i], 2e-6, "rotation / opacity", k);
      for (int64_t i = 11; i < R; ++i) check(g[i], w[i], 0.0, "colour", k);
    }
  }
  CHECK(bad == 0);
  return worst;
}

struct Case {
  uint32_t views, height, width, gs, dim;
  bool inverse, midground, extreme;
};

double run_case(const Case& c, uint32_t seed) {
  CAPTURE(c.views);
  CAPTURE(c.height);
  CAPTURE(c.width);
  CAPTURE(c.gs);
  CAPTURE(c.dim);
  CAPTURE(c.inverse);
  CAPTURE(c.extreme);
  std::mt19937 rng(seed);
  GsmPixelGaussiansShape s;
  s.views = c.views;
  s.height = c.height;
  s.width = c.width;
  s.gs_per_pixel = c.gs;
  s.gs_dim = c.dim;
  s.inverse_metric_depth = c.inverse;
  s.midground_only = c.midground;
  const int64_t V = c.views, P = static_cast<int64_t>(s.pixels()), GD = int64_t{c.gs} * c.dim;
  nn::CpuTensor params({V, GD, c.height, c.width});
  std::uniform_real_distribution<float> u(-4.0f, 4.0f);
  for (float& v : params.data) v = u(rng);
  if (c.extreme) {
    const float logits[] = {1e4f, -1e4f, 88.0f, -88.0f, 0.0f};
    std::uniform_int_distribution<int> pick(0, 4), which(0, 5);
    for (int64_t v = 0; v < V; ++v)
      for (int64_t g = 0; g < c.gs; ++g)
        for (int64_t p = 0; p < P; ++p) {
          auto at = [&](int64_t k) -> float& { return params.data[static_cast<size_t>(((v * GD) + g * c.dim + k) * P + p)]; };
          if (!c.inverse) at(0) = logits[pick(rng)];
          for (int k = 1; k <= 3; ++k) at(k) = logits[pick(rng)];
          at(8) = logits[pick(rng)];
          const int w = which(rng);
          const float qs = w == 0 ? 1e-30f : w == 1 ? 1e30f : w == 2 ? 0.0f : 1.0f;
          for (int k = 4; k < 8; ++k) at(k) *= qs;
        }
  }
  std::vector<float> fg(static_cast<size_t>(V * P)), grid(fg.size());
  std::bernoulli_distribution coin(0.5);
  for (size_t i = 0; i < fg.size(); ++i) {
    fg[i] = coin(rng) ? 1.0f : 0.0f;
    grid[i] = coin(rng) ? 1.0f : 0.0f;
  }
  std::vector<std::array<float, 16>> poses;
  std::vector<std::array<float, 6>> intrinsics;
  for (int64_t v = 0; v < V; ++v) {
    const auto [P4, K] = random_camera(rng, c.height, c.width, v == 0 ? 2.0f : 150.0f);
    poses.push_back(P4);
    intrinsics.push_back(K);
  }
  const std::vector<float> cameras = kernels::nn::pack_gsm_pixel_cameras(poses, intrinsics);
  const nn::cpu::GsmPixelGaussiansDense want = nn::cpu::gsm_pixel_gaussians(s, params, fg, grid, cameras);
  // The mask rule itself.
  for (size_t i = 0; i < fg.size(); ++i) REQUIRE(want.mask.data[i] == (c.midground ? fg[i] * (1.0f - grid[i]) : fg[i]));
  return compare(s, want, run_gpu(s, params, fg, grid, cameras), cameras);
}

nlohmann::json case_hparams(const std::string& dir) { return nlohmann::json::parse(scene::read_file(dir + "config.json")).at("hparams"); }

}  // namespace

TEST_CASE("gsm_pixel_gaussians gpu: every pixel's Gaussians against the CPU reference") {
  double worst = 0.0;
  uint32_t seed = 11;
  for (const Case& c : {Case{1, 1, 1, 1, 10, false, true, false}, Case{2, 13, 7, 2, 12, false, true, false},
                        Case{3, 9, 127, 3, 14, true, false, false}, Case{1, 16, 24, 2, 12, false, true, true},
                        Case{2, 5, 33, 2, 11, true, true, true}})
    worst = std::max(worst, run_case(c, seed += 17));
  MESSAGE("gsm_pixel_gaussians: worst |gpu - cpu| / tolerance = " << worst);
}

TEST_CASE("gsm_pixel_gaussians gpu: refused arguments") {
  gpu::Context& ctx = test::gpu_context();
  gpu::Buffer small(ctx, 64);
  kernels::nn::GsmPixelGaussians op(ctx);
  GsmPixelGaussiansShape s;
  s.height = s.width = 4;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    GsmPixelGaussiansShape bad = s;
    bad.gs_dim = 9;
    CHECK_THROWS_WITH_AS(op.record(cmd, bad, small, small, small, small, small, small), doctest::Contains("gs_dim >= 10"),
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(op.record(cmd, s, small, small, small, small, small, small), doctest::Contains("params buffer holds 64 bytes"),
                         std::invalid_argument);
  });
  CHECK_THROWS_AS(kernels::nn::pack_gsm_pixel_cameras({std::array<float, 16>{}}, {}), std::invalid_argument);
}

TEST_CASE("gsm_pixel_gaussians gpu: gsm_small's pixel Gaussians from pix.gs_params") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::PixelBranchConfig c = nn::pixel_branch_config_from_json(case_hparams(dir));
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  const test::GsmTensors ref(dir + "intermediates.safetensors"), outputs(dir + "outputs.safetensors");
  const int64_t V = in.batch * in.views, H = in.height, W = in.width, C = int64_t{c.gs_per_pixel} * c.gs_dim;

  // pix.gs_params [B, N, H, W, G * D] -> channel-major [V, G * D, H, W].
  const nn::CpuTensor gs_params = ref.get("pix.gs_params");
  nn::CpuTensor params({V, C, H, W});
  for (int64_t v = 0; v < V; ++v)
    for (int64_t p = 0; p < H * W; ++p)
      for (int64_t ch = 0; ch < C; ++ch)
        params.data[static_cast<size_t>((v * C + ch) * H * W + p)] = gs_params.data[static_cast<size_t>((v * H * W + p) * C + ch)];
  const std::vector<float> fg = nn::pixel_branch_foreground(in).data;
  const nn::CpuTensor grid_t = ref.get("pre.grid_fg_mask");
  const std::vector<uint8_t> grid_u8(grid_t.data.begin(), grid_t.data.end());
  const std::vector<float> cameras = kernels::nn::pack_gsm_pixel_cameras(in.poses, in.intrinsics);

  GsmPixelGaussiansShape s;
  s.views = static_cast<uint32_t>(V);
  s.height = static_cast<uint32_t>(H);
  s.width = static_cast<uint32_t>(W);
  s.gs_per_pixel = static_cast<uint32_t>(c.gs_per_pixel);
  s.gs_dim = static_cast<uint32_t>(c.gs_dim);
  s.znear = static_cast<float>(c.znear);
  s.zfar = static_cast<float>(c.zfar);
  s.max_scale = static_cast<float>(c.max_scale);
  s.inverse_metric_depth = c.inverse_metric_depth;
  s.midground_only = c.midground_only;

  // The dense CPU reference, compacted, is the reference decoder's output.
  const nn::cpu::GsmPixelGaussiansDense dense = nn::cpu::gsm_pixel_gaussians(s, params, fg, grid_t.data, cameras);
  const std::vector<nn::PixelGaussians> from_dense =
      nn::compact_pixel_gaussians(c, in.batch, in.views, H, W, dense.gaussians.data, dense.mask.data);
  const std::vector<nn::PixelGaussians> decoded = nn::decode_pixel_gaussians(c, in, gs_params, grid_u8, nullptr);
  REQUIRE(from_dense.size() == 1);
  REQUIRE(decoded.size() == 1);
  CHECK(from_dense[0].src == decoded[0].src);
  CHECK(nn::cpu::max_abs_over_std(from_dense[0].means.data, decoded[0].means.data) <= 1e-6);
  CHECK(nn::cpu::max_abs_over_std(from_dense[0].scales.data, decoded[0].scales.data) <= 1e-6);
  CHECK(nn::cpu::max_abs_over_std(from_dense[0].rotations.data, decoded[0].rotations.data) <= 1e-6);
  CHECK(nn::cpu::max_abs_over_std(from_dense[0].opacities.data, decoded[0].opacities.data) <= 1e-6);
  CHECK(from_dense[0].colors.data == decoded[0].colors.data);

  // The GPU kernel against the official outputs.
  const DenseResult got = run_gpu(s, params, fg, grid_t.data, cameras);
  MESSAGE("gsm_pixel_gaussians on gsm_small: worst |gpu - cpu| / tolerance = " << compare(s, dense, got, cameras));
  test::check_gsm_tensor(ref, "pix.gaussian_pixel_mask", nn::CpuTensor({in.batch, in.views, H, W}, got.mask));
  const std::vector<nn::PixelGaussians> gs = nn::compact_pixel_gaussians(c, in.batch, in.views, H, W, got.gaussians, got.mask);
  REQUIRE(gs.size() == 1);
  const nn::PixelGaussians& g = gs[0];
  test::check_gsm_tensor(outputs, "gs.b0.pixel.means", g.means);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.scales", g.scales);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.rotations", g.rotations);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.opacities", g.opacities);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.colors", g.colors);
  test::check_gsm_tensor(outputs, "gs.b0.pixel.src", nn::CpuTensor({g.count(), 4}, std::vector<float>(g.src.begin(), g.src.end())));
}
