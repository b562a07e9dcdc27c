// splat/to_rgba8.comp (splat/splat_rgba8.h) against its CPU reference: odd
// pixel counts, values outside [0, 1], ±Inf, NaN and the rounding halves.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "splat/splat_rgba8.h"

#include <cmath>
#include <limits>
#include <random>
#include <vector>

using namespace icube;

TEST_CASE("splat to_rgba8: GPU packing equals the CPU reference, extremes included") {
  gpu::Context& ctx = test::gpu_context();
  splat::SplatToRgba8 conv(ctx);
  for (const size_t pixels : {size_t{1}, size_t{517}, size_t{70001}}) {
    std::mt19937 rng{static_cast<uint32_t>(pixels)};
    std::uniform_real_distribution<float> u(-0.25f, 1.25f);
    std::vector<float> img(pixels * 4);
    for (float& v : img) v = u(rng);
    const float specials[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity(), 0.0f, 1.0f, -0.0f, 127.5f / 255.0f,
                              0.5f / 255.0f, 254.5f / 255.0f, 1e30f, -1e30f, 1.0f + 1e-7f};
    for (size_t i = 0; i < std::size(specials) && i < img.size(); ++i) img[i] = specials[i];
    for (size_t k = 0; k * 4 < img.size() && k < 256; ++k) img[4 * k + 1] = (float(k) + 0.5f) / 255.0f;  // halves
    const gpu::Buffer in = gpu::upload_vector(ctx, img, "test-image");
    gpu::Buffer out(ctx, pixels * 4, gpu::MemoryUsage::DeviceLocal, "test-rgba8");
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { conv.record(cmd, in, out, pixels); });
    const std::vector<uint32_t> got = gpu::download_vector<uint32_t>(ctx, out, pixels);
    const std::vector<uint32_t> want = splat::splat_to_rgba8_cpu(img);
    INFO(pixels << " pixels");
    CHECK(test::equal_report(got, want, "rgba8"));
  }
  CHECK(splat::splat_channel8(std::numeric_limits<float>::quiet_NaN()) == 0);
  CHECK(splat::splat_channel8(2.0f) == 255);
  CHECK(splat::splat_channel8(-1.0f) == 0);
  CHECK(splat::splat_channel8(0.5f / 255.0f) == 1);
}
