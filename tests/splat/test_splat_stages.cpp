// The GPU rasterizer's stage API (rasterizer_gpu.h): plan, record_preprocess,
// read_instances, record_bin, record_blend and finish recorded into a caller's
// own command lists give render()'s image bit for bit, on both binning paths.
// (Per-kernel comparisons with the CPU reference: test_splat.cpp.)
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "splat/rasterizer_gpu.h"
#include "test_splat_util.h"

#include <vector>

using namespace icube;
using splat::SplatOptions;

TEST_CASE("splat gpu: the stages recorded into a caller's command lists give render()'s image (both binning paths)") {
  const auto cloud = test::random_cloud(23, 3000, 2, {0.0, 0.0, 0.0}, 2.0);
  const auto cam = test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, 141, 87, 130.0, 3.5, -1.0);
  gpu::Context& ctx = test::gpu_context();
  for (const auto binning : {splat::TileBinning::Radix, splat::TileBinning::Counting}) {
    CAPTURE(int(binning));
    splat::SplatRendererGpu r(ctx, splat::SplatGpuVariant{true, true, binning});
    const auto g = r.upload(cloud);
    SplatOptions o;
    o.background = {0.1f, 0.2f, 0.3f};
    const auto want = r.render(g, cam, o);
    // A caller's own lists: preprocess, one readback, then binning and blend in one list.
    splat::SplatFramePlan p = r.plan(g, cam, o);
    ctx.submit_and_wait([&](gpu::CommandList& cmd) { r.record_preprocess(cmd, p); });
    CHECK(r.read_instances(p) > 0);
    CHECK(p.counting == (binning == splat::TileBinning::Counting));
    ctx.submit_and_wait([&](gpu::CommandList& cmd) {
      r.record_bin(cmd, p);
      r.record_blend(cmd, p);
    });
    REQUIRE(r.finish(p));
    const auto rgba = gpu::download_vector<float>(ctx, r.buffers().rgba, size_t{141} * 87 * 4);
    const auto depth = gpu::download_vector<float>(ctx, r.buffers().depth, size_t{141} * 87 * 2);
    CHECK(rgba == want.rgba);
    CHECK(depth == want.depth);
  }
}
