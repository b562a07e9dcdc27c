// Tests of the core's resource lifetimes and binding helpers: deferred
// destruction (Context::retire, gpu::ensure_capacity), the texel-view cache,
// gpu::null_binding() on push-descriptor and pooled-descriptor paths, and the
// dispatch arithmetic (div_up, align_up, tiled_threads).
#include <doctest/doctest.h>

#include "gpu/commands.h"
#include "gpu_test_context.h"
#include "kernels/prefix_scan.h"
#include "shared/primitives_params.h"

#include <algorithm>
#include <numeric>
#include <vector>

using namespace icube;

static_assert(gpu::div_up(0, 8) == 0 && gpu::div_up(1, 8) == 1 && gpu::div_up(8, 8) == 1 && gpu::div_up(9, 8) == 2);
static_assert(gpu::align_up(13, 4) == 16 && gpu::align_up(16, 4) == 16);
// An 833 x 481 image in 8 x 4 tiles of 32 invocations: 105 x 121 tiles.
static_assert(gpu::tiled_threads(833, 481, 8, 4, 32) == 105ull * 121 * 32);
static_assert(gpu::tiled_threads(1, 1, 16, 16, 64) == 64);

TEST_CASE("retired buffers outlive every command list open when they were retired") {
  gpu::Context& ctx = test::gpu_context();
  REQUIRE(ctx.retired_count() == 0);
  gpu::Buffer b(ctx, 1024, gpu::MemoryUsage::DeviceLocal, "retire-me");
  SUBCASE("no list open: destroyed at once") {
    ctx.retire(std::move(b));
    CHECK_FALSE(b.valid());
    CHECK(ctx.retired_count() == 0);
  }
  SUBCASE("retired while recording: kept until that list is destroyed") {
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      cmd.fill_buffer(b.binding(), 7u);
      ctx.retire(std::move(b));
      CHECK(ctx.retired_count() == 1);  // the fill above still uses it
    });
    CHECK(ctx.retired_count() == 0);  // the list is gone after its fence
  }
  SUBCASE("ensure_capacity retires the outgrown buffer") {
    gpu::Buffer grow(ctx, 16, gpu::MemoryUsage::DeviceLocal, "grow");
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      cmd.fill_buffer(grow.binding(), 1u);
      gpu::ensure_capacity(ctx, grow, 4096, "grow");
      CHECK(grow.size() >= 4096);
      CHECK(ctx.retired_count() == 1);
      cmd.barrier(gpu::deps::kTransferToTransfer);  // both fills write; the new buffer is separate
      cmd.fill_buffer(grow.binding(), 2u);
    });
    CHECK(ctx.retired_count() == 0);
    const auto v = gpu::download_vector<uint32_t>(ctx, grow, grow.size() / 4);
    CHECK(std::all_of(v.begin(), v.end(), [](uint32_t x) { return x == 2u; }));
  }
}

TEST_CASE("texel views are cached per (buffer, format, range), bounded per buffer and freed with the buffer") {
  gpu::Context& ctx = test::gpu_context();
  const size_t before = ctx.cached_view_count();
  {
    gpu::Buffer b(ctx, 1 << 16, gpu::MemoryUsage::DeviceLocal, "views");
    const VkBufferView v1 = ctx.texel_view(b.handle(), VK_FORMAT_R32_UINT, 0, 256);
    CHECK(ctx.texel_view(b.handle(), VK_FORMAT_R32_UINT, 0, 256) == v1);  // cached
    CHECK(ctx.texel_view(b.handle(), VK_FORMAT_R32G32B32A32_UINT, 0, 256) != v1);
    CHECK(ctx.cached_view_count() == before + 2);
    // A buffer bound with a new range every frame: the cache stays bounded.
    for (VkDeviceSize r = 1; r <= 40; ++r) ctx.texel_view(b.handle(), VK_FORMAT_R32_UINT, 256, r * 16);
    CHECK(ctx.cached_view_count() == before + gpu::Context::kMaxViewsPerBuffer);
  }
  CHECK(ctx.cached_view_count() == before);  // released with the buffer
}

// scan_tiles with has_prefix = 0 does not read its tile_prefix binding: a null binding there.
static void scan_with_null_prefix(gpu::Context& ctx) {
  const uint32_t n = 1000;
  std::vector<uint32_t> in(n);
  std::iota(in.begin(), in.end(), 1u);
  gpu::Buffer src = gpu::upload_vector(ctx, in, "in"), dst(ctx, n * 4);
  kernels::PrefixScan scan(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { scan.record(cmd, src, dst, n, kernels::ScanKind::Inclusive, nullptr); });
  std::vector<uint32_t> want(n);
  std::inclusive_scan(in.begin(), in.end(), want.begin());
  CHECK(test::equal_report(gpu::download_vector<uint32_t>(ctx, dst, n), want, "scan"));
}

TEST_CASE("null bindings stand for inputs a kernel does not read, with push and pooled descriptors") {
  SUBCASE("push descriptors (where present)") { scan_with_null_prefix(test::gpu_context()); }
  SUBCASE("pooled descriptor sets") {
    gpu::ContextOptions opts = gpu::ContextOptions::from_env();
    opts.disable_push_descriptors = true;
    auto ctx = test::make_validated_context(opts);
    scan_with_null_prefix(*ctx);
  }
  SUBCASE("the zero buffer is 256 zero bytes") {
    gpu::Context& ctx = test::gpu_context();
    const auto z = gpu::download_vector<uint32_t>(ctx, ctx.null_buffer(), 64);
    CHECK(std::all_of(z.begin(), z.end(), [](uint32_t x) { return x == 0u; }));
  }
}
