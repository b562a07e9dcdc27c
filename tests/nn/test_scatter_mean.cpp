// The voxel lifter's scatter-mean (kernels/nn/scatter_mean.h,
// shaders/nn/scatter_mean.comp): the host's per-voxel pixel lists on a hand
// example; the CPU reference (nn::cpu::scatter_mean, the GSM reference's
// lifter) on hand-computed means; the GPU kernel against the CPU reference on
// fixed seeds — 3 views of an odd 7 x 9 image, 5 channels, skewed first voxels
// (empty voxels, -1 pixels, masked pixels, one voxel taking many pixels), large
// activations — with the bound of a float32 sum in list order,
// 2^-23 (k + 1) mean|x| for a list of k pixels (empty voxels exactly 0); two
// runs bitwise equal; windows (views; channels of one view; voxel ranges;
// passes of 2 list entries, and a list beyond NN_SM_PIXEL_WINDOW) bitwise equal
// to one dispatch; no effective pixel at all; then gsm_small's vox.lifter.in
// from the reference conv features. Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "kernels/nn/scatter_mean.h"
#include "nn/gsm/gsm_inputs.h"
#include "shared/nn_gsm_params.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <stdexcept>

using namespace icube;

namespace {

struct LifterCase {
  nn::CpuTensor features;            // [N, C, H, W]
  std::vector<int32_t> first_voxel;  // N * H * W
  nn::CpuTensor mask;                // [N, H, W]
  int64_t voxels = 0;
};

// Skewed first voxels (floor(V u^3): low rows take many pixels, high rows few or none), 20 % -1, 25 % masked;
// N(0, 1) features plus 2, every 7th pixel scaled by `large`.
LifterCase random_case(int64_t N, int64_t C, int64_t H, int64_t W, int64_t V, uint32_t seed, float large = 1.0f) {
  LifterCase k;
  k.voxels = V;
  k.features = nn::CpuTensor({N, C, H, W});
  k.mask = nn::CpuTensor({N, H, W});
  std::mt19937 rng(seed);
  std::normal_distribution<float> nd(0.0f, 1.0f);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int64_t HW = H * W;
  for (int64_t n = 0; n < N; ++n)
    for (int64_t c = 0; c < C; ++c)
      for (int64_t p = 0; p < HW; ++p)
        k.features.data[static_cast<size_t>((n * C + c) * HW + p)] = (nd(rng) + 2.0f) * ((n * HW + p) % 7 == 3 ? large : 1.0f);
  k.first_voxel.resize(static_cast<size_t>(N * HW));
  for (int32_t& r : k.first_voxel) {
    const double a = u(rng);
    r = u(rng) < 0.2 ? -1 : static_cast<int32_t>(std::min<double>(static_cast<double>(V) - 1, std::floor(static_cast<double>(V) * a * a * a)));
  }
  for (float& m : k.mask.data) m = u(rng) < 0.25 ? 0.0f : 1.0f;
  return k;
}

struct GpuRun {
  std::vector<float> y;
  kernels::nn::VoxelPixelLists lists;
};

GpuRun run_gpu(const LifterCase& k, uint64_t max_binding_bytes = 0, uint32_t pixel_window = 0) {
  gpu::Context& ctx = test::gpu_context();
  GpuRun r;
  r.lists = kernels::nn::build_voxel_pixel_lists(k.first_voxel, k.mask.data, static_cast<uint32_t>(k.voxels));
  const kernels::nn::ScatterMeanShape s{static_cast<uint32_t>(k.features.dim(0)), static_cast<uint32_t>(k.features.dim(1)),
                                        static_cast<uint32_t>(k.features.dim(2)), static_cast<uint32_t>(k.features.dim(3))};
  gpu::Buffer fb = gpu::upload_vector(ctx, k.features.data, "sm-features");
  gpu::Buffer ob = gpu::upload_vector(ctx, r.lists.offsets, "sm-offsets");
  gpu::Buffer pb = gpu::upload_vector(ctx, r.lists.pixel_ids, "sm-pixels");
  const size_t n = static_cast<size_t>(k.voxels * k.features.dim(1));
  gpu::Buffer yb(ctx, std::max<size_t>(n, 1) * 4, gpu::MemoryUsage::DeviceLocal, "sm-y");
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { cmd.fill_buffer(yb.binding(), 0x7fc00000u); });  // NaN: every element must be written
  kernels::nn::ScatterMean sm(ctx);
  sm.set_max_binding_bytes(max_binding_bytes);
  sm.set_pixel_window(pixel_window);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    cmd.barrier(gpu::deps::kTransferToCompute);
    sm.record(cmd, s, fb, r.lists, ob, pb, yb);
  });
  r.y = gpu::download_vector<float>(ctx, yb, n);
  return r;
}

bool bitwise_equal(const std::vector<float>& a, const std::vector<float>& b, const char* what) {
  if (a.size() != b.size() || (!a.empty() && std::memcmp(a.data(), b.data(), a.size() * 4) != 0)) {
    size_t shown = 0;
    for (size_t i = 0; i < std::min(a.size(), b.size()) && shown < 5; ++i)
      if (std::memcmp(&a[i], &b[i], 4) != 0 && ++shown)
        std::printf("  %s: element %zu %.9g vs %.9g\n", what, i, static_cast<double>(a[i]), static_cast<double>(b[i]));
    return false;
  }
  return true;
}

// GPU against the CPU reference within the float32 sum's bound; returns the GPU result.
std::vector<float> check_against_cpu(const LifterCase& k, uint64_t max_binding_bytes = 0, uint32_t pixel_window = 0) {
  CAPTURE(max_binding_bytes);
  CAPTURE(pixel_window);
  const GpuRun r = run_gpu(k, max_binding_bytes, pixel_window);
  const nn::CpuTensor want = nn::cpu::scatter_mean(k.features, k.first_voxel, k.mask, k.voxels);
  nn::CpuTensor abs_features = k.features;
  for (float& v : abs_features.data) v = std::abs(v);
  const nn::CpuTensor mean_abs = nn::cpu::scatter_mean(abs_features, k.first_voxel, k.mask, k.voxels);
  const int64_t C = k.features.dim(1);
  REQUIRE(r.y.size() == want.data.size());
  size_t bad = 0;
  double worst = 0.0;
  for (size_t i = 0; i < r.y.size(); ++i) {
    const uint32_t v = static_cast<uint32_t>(static_cast<int64_t>(i) / C);
    const double count = r.lists.offsets[v + 1] - r.lists.offsets[v];
    const double tol = std::ldexp(1.0, -23) * (count + 1.0) * static_cast<double>(mean_abs.data[i]);  // 0 for empty voxels
    const double err = std::abs(static_cast<double>(r.y[i]) - static_cast<double>(want.data[i]));
    if (tol > 0) worst = std::max(worst, err / tol);
    if (!(err <= tol) && ++bad <= 5)
      std::printf("  scatter_mean mismatch at voxel %u channel %lld (%g pixels): got %.9g want %.9g (tol %.3g)\n", v,
                  static_cast<long long>(static_cast<int64_t>(i) % C), count, static_cast<double>(r.y[i]),
                  static_cast<double>(want.data[i]), tol);
  }
  std::printf("  scatter_mean %s -> %lld voxels, cap %llu, window %u: worst error %.3g of the bound\n", k.features.shape_text().c_str(),
              static_cast<long long>(k.voxels), static_cast<unsigned long long>(max_binding_bytes), pixel_window, worst);
  CHECK(bad == 0);
  return r.y;
}

uint64_t binding_bytes_for(uint64_t elements) {
  const gpu::DeviceInfo& info = test::gpu_context().info();
  return elements * 4 + std::max<uint64_t>({4, info.min_storage_buffer_offset_alignment, info.min_texel_buffer_offset_alignment});
}

}  // namespace

TEST_CASE("scatter_mean lists: effective pixels grouped by voxel in pixel order") {
  const std::vector<int32_t> first{2, -1, 0, 2, 1, 2, 0};
  const std::vector<float> mask{1, 1, 0, 1, 1, 1, 1};
  const kernels::nn::VoxelPixelLists l = kernels::nn::build_voxel_pixel_lists(first, mask, 4);
  CHECK(l.voxels == 4);
  CHECK(l.pixels == 7);
  CHECK(l.offsets == std::vector<uint32_t>{0, 1, 2, 5, 5});
  CHECK(l.pixel_ids == std::vector<uint32_t>{6, 4, 0, 3, 5});
  CHECK(l.max_count == 3);
  CHECK_THROWS_AS(kernels::nn::build_voxel_pixel_lists(first, mask, 2), std::invalid_argument);  // row 2 of 2 voxels
  CHECK_THROWS_AS(kernels::nn::build_voxel_pixel_lists(first, {1, 1}, 4), std::invalid_argument);
}

TEST_CASE("scatter_mean reference: hand-computed means, masked pixels and empty voxels") {
  // One view of 1 x 3 pixels, 2 channels; pixels 0 and 1 hit voxel 0, pixel 2 voxel 2, voxel 1 gets nothing.
  const nn::CpuTensor features({1, 2, 1, 3}, std::vector<float>{1.f, 2.f, 4.f, 10.f, 20.f, 40.f});
  const std::vector<int32_t> first{0, 0, 2};
  CHECK(nn::cpu::scatter_mean(features, first, nn::CpuTensor({1, 1, 3}, 1.0f), 3).data ==
        std::vector<float>{1.5f, 15.f, 0.f, 0.f, 4.f, 40.f});
  // Pixel 1 not effective: voxel 0 holds pixel 0 alone.
  CHECK(nn::cpu::scatter_mean(features, first, nn::CpuTensor({1, 1, 3}, std::vector<float>{1.f, 0.f, 1.f}), 3).data ==
        std::vector<float>{1.f, 10.f, 0.f, 0.f, 4.f, 40.f});
  // No pixel hits anything: all zeros.
  CHECK(nn::cpu::scatter_mean(features, {-1, -1, -1}, nn::CpuTensor({1, 1, 3}, 1.0f), 2).data == std::vector<float>(4, 0.f));
}
TEST_CASE("scatter_mean gpu: the per-voxel mean against the CPU reference, deterministic") {
  const LifterCase k = random_case(3, 5, 7, 9, 37, 11, 3e4f);
  const std::vector<float> first = check_against_cpu(k);
  const GpuRun again = run_gpu(k);
  CHECK(bitwise_equal(again.y, first, "second run"));
  // A voxel row with no pixel reads exactly 0 (there are some in this case).
  const kernels::nn::VoxelPixelLists& l = again.lists;
  int empty = 0;
  for (uint32_t v = 0; v < l.voxels; ++v)
    if (l.offsets[v] == l.offsets[v + 1]) {
      ++empty;
      for (int64_t c = 0; c < 5; ++c) CHECK(first[static_cast<size_t>(v * 5 + c)] == 0.0f);
    }
  CHECK(empty > 0);
  CHECK(l.max_count > 10);
  check_against_cpu(random_case(1, 1, 1, 1, 1, 12));    // one pixel, one voxel
  check_against_cpu(random_case(2, 16, 5, 3, 64, 13));  // the GSM's width, more voxels than pixels
  LifterCase none = random_case(2, 3, 4, 5, 6, 14);
  std::fill(none.mask.data.begin(), none.mask.data.end(), 0.0f);  // nothing effective: all zero
  const std::vector<float> zeros = check_against_cpu(none);
  CHECK(std::all_of(zeros.begin(), zeros.end(), [](float v) { return v == 0.0f; }));
}

TEST_CASE("scatter_mean gpu: windows and passes continue the same sums bitwise") {
  const LifterCase k = random_case(3, 5, 7, 9, 101, 21, 3e4f);
  const std::vector<float> whole = check_against_cpu(k);
  const uint64_t per_view = 5 * 63;
  // Two views per feature window (the second window searches its sub-lists).
  CHECK(bitwise_equal(check_against_cpu(k, binding_bytes_for(2 * per_view)), whole, "view windows"));
  // Channel windows of one view (3 of 5 channels = 189 floats), voxel windows of 40 rows (200 / 5).
  CHECK(bitwise_equal(check_against_cpu(k, binding_bytes_for(200)), whole, "channel and voxel windows"));
  // And passes of 2 list entries per dispatch.
  CHECK(bitwise_equal(check_against_cpu(k, binding_bytes_for(200), 2), whole, "passes"));
  CHECK(bitwise_equal(check_against_cpu(k, 0, 3), whole, "passes in one window"));
  // One voxel list beyond NN_SM_PIXEL_WINDOW entries (lavapipe's loop budget): 48 x 1000 pixels, all to voxel 0
  // but every 5th (to voxel 1), two passes at the default window.
  LifterCase big = random_case(1, 2, 48, 1000, 2, 22);
  for (size_t q = 0; q < big.first_voxel.size(); ++q) big.first_voxel[q] = q % 5 == 0 ? 1 : 0;
  std::fill(big.mask.data.begin(), big.mask.data.end(), 1.0f);
  const std::vector<float> big_y = check_against_cpu(big);
  CHECK(kernels::nn::build_voxel_pixel_lists(big.first_voxel, big.mask.data, 2).max_count > NN_SM_PIXEL_WINDOW);
  CHECK(bitwise_equal(check_against_cpu(big, 0, 10000), big_y, "big list in passes of 10000"));
}

TEST_CASE("scatter_mean gpu: gsm_small's vox.lifter.in from the reference conv features") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  REQUIRE(in.batch == 1);
  LifterCase k;
  k.features = ref.get("enc.conv.out");  // [1, N, C, H, W] -> [N, C, H, W]
  k.features.shape.erase(k.features.shape.begin());
  const nn::CpuTensor first = ref.get("vox.lifter.pixel_first_voxel.b0");
  for (float f : first.data) k.first_voxel.push_back(static_cast<int32_t>(f));
  k.mask = nn::gsm_effective_mask(in);
  k.mask.shape.erase(k.mask.shape.begin());
  k.voxels = ref.get("vox.lifter.in").dim(0);
  const GpuRun r = run_gpu(k);
  test::check_gsm_tensor(ref, "vox.lifter.in", nn::CpuTensor({k.voxels, k.features.dim(1)}, r.y));
  CHECK(bitwise_equal(run_gpu(k).y, r.y, "second run"));
}
