// The GSM voxel branch's projected-feature sampling on the GPU
// (kernels/nn/gsm_project_features.h, shaders/nn/gsm_project_features*.comp)
// against its double CPU reference (nn::cpu::gsm_project_features): 1, 3 and
// 31 views (the maximum from -inf and from 0), children projecting inside,
// across the image border, far outside and behind the camera, masked pixels,
// views that did not see the parent (they give 0, which wins over negative
// samples), parents seen by no view; the float32 projection
// (gsm_project_features.comp) and the double one (gsm_project_features_f64.comp,
// where the device has shaderFloat64); and windows of views, channels and
// children with storage bindings capped at 4 KiB. Bounds for features in [-1, 1]:
// 5e-5 with the float32 projection (it moves the sample point by ~1e-5 pixel
// and the masked bilinear interpolation is 2-Lipschitz per pixel), 1e-6 with
// the double one (the float32 bilinear sum). Runs under the validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu_test_context.h"
#include "kernels/nn/gsm_project_features.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <tuple>

using namespace icube;

namespace {

struct ProjectCase {
  nn::CpuTensor features, mask;
  std::vector<int32_t> ijk, parent;
  std::vector<uint32_t> seen;
  std::vector<double> proj;
  std::array<double, 3> voxel_size{0.25, 0.25, 0.25};
  std::array<double, 3> origin{-2.0, -1.5, -1.0};
};

// Views looking along +z from cameras spread along x (identity rotation), focal 0.35 of the width: children
// in [-2, 3] x [-1.5, 2] x [-1, 5] project inside, outside and behind.
ProjectCase make_case(int64_t views, int64_t channels, int64_t h, int64_t w, int64_t rows, int64_t parents, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  ProjectCase c;
  c.features = nn::CpuTensor({views, channels, h, w});
  for (float& v : c.features.data) v = u(rng);
  c.mask = nn::CpuTensor({views, h, w});
  for (float& v : c.mask.data) v = u(rng) > -0.4f ? 1.0f : 0.0f;
  std::uniform_int_distribution<int32_t> ix(0, 20), iy(0, 14), iz(0, 24), ip(0, static_cast<int32_t>(parents) - 1);
  for (int64_t r = 0; r < rows; ++r) {
    c.ijk.insert(c.ijk.end(), {ix(rng), iy(rng), iz(rng)});
    c.parent.push_back(ip(rng));
  }
  // Parent 0 is seen by no view; the others by each view with probability 0.6.
  for (int64_t p = 0; p < parents; ++p)
    for (int64_t n = 0; n < views; ++n) c.seen.push_back(p > 0 && u(rng) > -0.2f ? 1u : 0u);
  for (int64_t n = 0; n < views; ++n) {
    const double fx = 0.35, fy = 0.35 * static_cast<double>(w) / static_cast<double>(h), cx = 0.5, cy = 0.5;
    const double tx = -0.3 * static_cast<double>(n % 5) + 0.4, ty = 0.05 * static_cast<double>(n % 3), tz = 0.2;
    c.proj.insert(c.proj.end(), {fx, 0.0, cx, fx * tx + cx * tz, 0.0, fy, cy, fy * ty + cy * tz, 0.0, 0.0, 1.0, tz});
  }
  return c;
}

// The windows the last run_gpu recorded.
size_t g_last_windows = 0;

std::vector<float> run_gpu(const ProjectCase& c, bool from_zero, bool float32, gpu::Context& ctx = test::gpu_context()) {
  const int64_t N = c.features.dim(0), C = c.features.dim(1), R = static_cast<int64_t>(c.parent.size());
  gpu::Buffer f = gpu::upload_vector(ctx, c.features.data, "project-features");
  gpu::Buffer m = gpu::upload_vector(ctx, c.mask.data, "project-mask");
  gpu::Buffer ijk = gpu::upload_vector(ctx, c.ijk, "project-ijk");
  gpu::Buffer parent = gpu::upload_vector(ctx, c.parent, "project-parent");
  gpu::Buffer seen = gpu::upload_vector(ctx, c.seen, "project-seen");
  gpu::Buffer proj = gpu::upload_vector(ctx, kernels::nn::gsm_projection_pairs(c.proj), "project-proj");
  gpu::Buffer y(ctx, static_cast<uint64_t>(R * C) * 4, gpu::MemoryUsage::DeviceLocal, "project-y");
  kernels::nn::GsmProjectShape s;
  s.rows = static_cast<uint32_t>(R);
  s.parents = static_cast<uint32_t>(c.seen.size() / static_cast<size_t>(N));
  s.channels = static_cast<uint32_t>(C);
  s.views = static_cast<uint32_t>(N);
  s.height = static_cast<uint32_t>(c.features.dim(2));
  s.width = static_cast<uint32_t>(c.features.dim(3));
  s.voxel_size = c.voxel_size;
  s.origin = c.origin;
  s.max_from_zero = from_zero;
  kernels::nn::GsmProjectFeatures k(ctx);
  k.force_float32(float32);
  const std::vector<kernels::nn::GsmProjectWindow> windows = k.windows(s);
  g_last_windows = windows.size();
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    for (const kernels::nn::GsmProjectWindow& w : windows) {
      if (w.barrier_before) cmd.barrier(gpu::deps::kComputeToCompute);
      k.record(cmd, s, w, f, m, ijk, parent, seen, proj, y);
    }
  });
  return gpu::download_vector<float>(ctx, y, static_cast<size_t>(R * C));
}

// Compares GPU [C][R] with the CPU [R, C]; returns the worst difference.
double compare(const ProjectCase& c, bool from_zero, bool float32, int64_t& nonzero, int64_t& negative,
               gpu::Context& ctx = test::gpu_context()) {
  const nn::CpuTensor want =
      nn::cpu::gsm_project_features(c.features, c.mask, c.ijk, c.parent, c.seen, c.proj, c.voxel_size, c.origin, from_zero);
  const std::vector<float> got = run_gpu(c, from_zero, float32, ctx);
  const int64_t R = want.dim(0), C = want.dim(1);
  double worst = 0.0;
  for (int64_t r = 0; r < R; ++r)
    for (int64_t ch = 0; ch < C; ++ch) {
      const double g = got[static_cast<size_t>(ch * R + r)], w = want.data[static_cast<size_t>(r * C + ch)];
      worst = std::max(worst, std::abs(g - w));
      nonzero += w != 0.0;
      negative += w < 0.0;
    }
  return worst;
}

}  // namespace

TEST_CASE("gsm_project_features gpu: sampling, masks and the maximum over views match the CPU reference") {
  const bool has_double = test::gpu_context().info().shader_float64;
  double worst[2] = {0.0, 0.0};  // float32 projection, the default (double where the device has it)
  for (const auto& [views, channels, h, w, rows, from_zero] :
       {std::tuple{1, 5, 12, 20, 300, false}, {3, 4, 11, 17, 400, false}, {3, 4, 11, 17, 400, true}, {31, 3, 6, 9, 200, true},
        {31, 3, 6, 9, 200, false}})
    for (const bool float32 : {true, false}) {
      CAPTURE(views);
      CAPTURE(from_zero);
      CAPTURE(float32);
      const ProjectCase c = make_case(views, channels, h, w, rows, 12, static_cast<uint32_t>(7 * views + channels));
      int64_t nonzero = 0, negative = 0;
      const double e = compare(c, from_zero, float32, nonzero, negative);
      CHECK(e <= (float32 || !has_double ? 5e-5 : 1e-6));
      worst[float32 ? 0 : 1] = std::max(worst[float32 ? 0 : 1], e);
      // Not degenerate: many samples land inside; with few views and a maximum from -inf some are negative.
      CHECK(nonzero > rows * channels / 4);
      if (!from_zero && views <= 3) CHECK(negative > 0);
      if (from_zero) CHECK(negative == 0);
    }
  const std::string second = has_double ? " (double projection)" : " (float32: no shaderFloat64)";
  MESSAGE("gsm_project_features: worst |gpu - cpu| = " << worst[0] << " (float32 projection), " << worst[1] << second);
}

TEST_CASE("gsm_project_features gpu: a view that did not see the parent gives 0, not its sample") {
  // One child at the image centre of both views, every feature -1: seen by view 0 only -> max(-1, 0) = 0 from
  // -inf; seen by both -> -1; seen by none -> 0.
  ProjectCase c;
  c.features = nn::CpuTensor({2, 1, 4, 4}, -1.0f);
  c.mask = nn::CpuTensor({2, 4, 4}, 1.0f);
  c.voxel_size = {1.0, 1.0, 1.0};
  c.origin = {0.0, 0.0, 0.0};
  c.ijk = {0, 0, 2, 0, 0, 2, 0, 0, 2};
  c.parent = {0, 1, 2};
  c.seen = {1, 0, 1, 1, 0, 0};
  for (int n = 0; n < 2; ++n) c.proj.insert(c.proj.end(), {1.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0, 1.0, 0.0});
  for (const bool float32 : {true, false}) CHECK(run_gpu(c, false, float32) == std::vector<float>{0.0f, -1.0f, 0.0f});
}

TEST_CASE("gsm_project_features gpu: tensors past one storage binding go in windows of views, channels and children") {
  // 4 KiB bindings (~1,000 values): 7 views of 3 channels of 10 x 14 (140 values a plane) go three views at a
  // time (later views take the maximum with the earlier ones' output); 600 children of 3 channels in windows
  // of one channel and ~330 children; from -inf and from 0, both projections.
  gpu::Context& capped = test::capped_gpu_context(4u << 10);
  for (const bool from_zero : {false, true})
    for (const bool float32 : {true, false}) {
      CAPTURE(from_zero);
      CAPTURE(float32);
      const ProjectCase c = make_case(7, 3, 10, 14, 600, 12, 91u);
      int64_t nonzero = 0, negative = 0;
      const double e = compare(c, from_zero, float32, nonzero, negative, capped);
      MESSAGE("windows: " << g_last_windows);
      CHECK(g_last_windows >= 12);
      CHECK(e <= (float32 || !capped.info().shader_float64 ? 5e-5 : 1e-6));
      CHECK(nonzero > 600 * 3 / 4);
    }
}

TEST_CASE("gsm_project_features gpu: gsm_project_features_f64 (the double projection) runs where the device has shaderFloat64") {
  gpu::Context& ctx = test::gpu_context();
  kernels::nn::GsmProjectFeatures k(ctx);
  CHECK(k.projects_in_double() == ctx.info().shader_float64);
  k.force_float32(true);
  CHECK_FALSE(k.projects_in_double());
  const std::string which = ctx.info().shader_float64 ? "gsm_project_features_f64: tested above"
                                                     : "no shaderFloat64: the float32 shader stands in";
  MESSAGE(which);
}
