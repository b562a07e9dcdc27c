// The GSM voxel heads' Gaussian decoding on the GPU
// (kernels/nn/gsm_voxel_gaussians.h, shaders/nn/gsm_voxel_gaussians.comp)
// against its double CPU reference (nn::cpu::gsm_voxel_gaussians): 4 and 1
// Gaussians per voxel, 3 and 5 colour values, scales clamped or not, extreme
// raw values (exp overflowing, sigmoid saturating, tiny quaternions), and two
// heads appended into the same outputs (first_gaussian). Bounds: means 1e-6 of
// the coordinate range, scales 2e-6 relative, rotations and opacities 1e-6,
// colours exact; and with storage bindings capped at 16 KiB, the windows of
// subs and voxels. Runs under the validation layer.
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu_test_context.h"
#include "kernels/nn/gsm_voxel_gaussians.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>

using namespace icube;

namespace {

struct Head {
  nn::CpuTensor raw;  // [rows, G * D]
  std::vector<int32_t> ijk;
  std::array<float, 3> voxel_size, origin;
};

Head make_head(int64_t rows, int64_t G, int64_t D, float vs, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  std::uniform_int_distribution<int32_t> coord(-80, 150);
  Head h{nn::CpuTensor({rows, G * D}), {}, {vs, vs, vs}, {vs / 2, vs / 2, vs / 2}};
  for (float& v : h.raw.data) v = u(rng);
  for (int64_t r = 0; r < rows; ++r) h.ijk.insert(h.ijk.end(), {coord(rng), coord(rng), coord(rng)});
  // Extremes in the first voxel: exp overflowing float, saturated sigmoids, a tiny quaternion.
  float* v = h.raw.data.data();
  v[0] = 100.0f;
  v[1] = -100.0f;
  v[3] = 120.0f;
  v[4] = -120.0f;
  for (int a = 6; a < 10; ++a) v[a] = 1e-14f * static_cast<float>(a);  // norm ~2.5e-13, below the 1e-12 floor
  v[10] = -95.0f;
  return h;
}

double max_rel(const std::vector<float>& got, const std::vector<float>& want, double floor) {
  double worst = 0.0;
  for (size_t i = 0; i < got.size(); ++i) {
    const double g = got[i], w = want[i];
    if (std::isinf(w) || std::isinf(g)) {
      worst = std::max(worst, g == w ? 0.0 : 1e30);
      continue;
    }
    worst = std::max(worst, std::abs(g - w) / std::max(std::abs(w), floor));
  }
  return worst;
}

// Two heads of rows_a and rows_b voxels decoded into the same outputs; returns the dispatches of the first.
size_t check_decoding(gpu::Context& ctx, int64_t rows_a, int64_t rows_b) {
  size_t dispatches = 0;
  for (const auto& [G, D, max_scaling] : {std::tuple{4, 14, 1.0f}, {1, 16, 0.0f}, {4, 14, 0.0f}}) {
    CAPTURE(G);
    CAPTURE(D);
    CAPTURE(max_scaling);
    const Head a = make_head(rows_a, G, D, 0.1f, 11u + static_cast<uint32_t>(D)),
               b = make_head(rows_b, G, D, 0.2f, 29u + static_cast<uint32_t>(G));
    const int64_t n = (rows_a + rows_b) * G, colors = D - 11;
    gpu::Buffer means(ctx, static_cast<uint64_t>(n) * 12), scales(ctx, static_cast<uint64_t>(n) * 12),
        rotations(ctx, static_cast<uint64_t>(n) * 16), opacities(ctx, static_cast<uint64_t>(n) * 4),
        color(ctx, static_cast<uint64_t>(n * colors) * 4);
    std::vector<gpu::Buffer> keep;
    kernels::nn::GsmVoxelGaussians k(ctx);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      uint32_t first = 0;
      for (const Head* h : {&a, &b}) {
        const int64_t rows = h->raw.dim(0);
        std::vector<float> cm(h->raw.data.size());  // the head output is channel-major
        for (int64_t r = 0; r < rows; ++r)
          for (int64_t ch = 0; ch < G * D; ++ch) cm[static_cast<size_t>(ch * rows + r)] = h->raw.data[static_cast<size_t>(r * G * D + ch)];
        keep.push_back(gpu::upload_vector(ctx, cm, "gaussians-raw"));
        keep.push_back(gpu::upload_vector(ctx, h->ijk, "gaussians-ijk"));
        kernels::nn::GsmVoxelGaussiansShape s;
        s.rows = static_cast<uint32_t>(rows);
        s.per_voxel = static_cast<uint32_t>(G);
        s.gs_dim = static_cast<uint32_t>(D);
        s.first_gaussian = first;
        s.voxel_size = h->voxel_size;
        s.origin = h->origin;
        s.scale_unit = h->voxel_size[0];
        s.max_scaling = max_scaling;
        k.record(cmd, s, keep[keep.size() - 2], keep.back(), {&means, &scales, &rotations, &opacities, &color});
        if (h == &a) dispatches = std::max(dispatches, k.last_dispatches());
        first += static_cast<uint32_t>(rows * G);
      }
    });
    nn::cpu::GsmGaussians want;
    for (const Head* h : {&a, &b}) {
      const nn::cpu::GsmGaussians part = nn::cpu::gsm_voxel_gaussians(h->raw, h->ijk, G, D, h->voxel_size, h->origin, h->voxel_size[0], max_scaling);
      auto append = [](nn::CpuTensor& to, const nn::CpuTensor& from) { to.data.insert(to.data.end(), from.data.begin(), from.data.end()); };
      append(want.means, part.means);
      append(want.scales, part.scales);
      append(want.rotations, part.rotations);
      append(want.opacities, part.opacities);
      append(want.colors, part.colors);
    }
    const std::vector<float> gm = gpu::download_vector<float>(ctx, means, static_cast<size_t>(n * 3));
    double mean_err = 0.0;
    for (size_t i = 0; i < gm.size(); ++i) mean_err = std::max(mean_err, std::abs(static_cast<double>(gm[i]) - static_cast<double>(want.means.data[i])));
    CHECK(mean_err <= 1e-6 * 30.0);  // coordinates span ~30 m
    CHECK(max_rel(gpu::download_vector<float>(ctx, scales, static_cast<size_t>(n * 3)), want.scales.data, 1e-30) <= 2e-6);
    CHECK(max_rel(gpu::download_vector<float>(ctx, rotations, static_cast<size_t>(n * 4)), want.rotations.data, 1.0) <= 1e-6);
    CHECK(max_rel(gpu::download_vector<float>(ctx, opacities, static_cast<size_t>(n)), want.opacities.data, 1.0) <= 1e-6);
    CHECK(gpu::download_vector<float>(ctx, color, static_cast<size_t>(n * colors)) == want.colors.data);
    // The extremes decoded as the reference: overflowing scales clamped or infinite, the tiny quaternion divided
    // by the 1e-12 floor (not made a unit).
    CHECK(want.scales.data[0] == (max_scaling > 0.0f ? max_scaling : INFINITY));
    CHECK(want.rotations.data[0] == doctest::Approx(0.06).epsilon(1e-5));
  }
  return dispatches;
}

}  // namespace

TEST_CASE("gsm_voxel_gaussians gpu: decoding matches the CPU reference, two heads appended") {
  CHECK(check_decoding(test::gpu_context(), 37, 23) == 1);
}

TEST_CASE("gsm_voxel_gaussians gpu: heads past one storage binding decode in windows of subs and voxels") {
  // 16 KiB bindings (~4,000 values): 260 voxels of 4 x 14 raw values go one sub at a time, each in two
  // windows of voxels (the rotations' 4 values per Gaussian); the 23-voxel head in one window of all its subs.
  CHECK(check_decoding(test::capped_gpu_context(16u << 10), 260, 23) == 8);
}
