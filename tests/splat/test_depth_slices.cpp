// A splatting frame in depth slices (engine/splat/depth_slices.h, shaders/splat/slice_*.comp,
// splat/blend.comp's carried state): the kernels slice_keys, slice_histogram, slice_flags and
// slice_gather one by one against their CPU references; the slice planner on hand-made histograms (limits,
// refinement of an over-full bucket, a key shared by too many Gaussians), and on the GPU, with
// storage bindings capped at 64 KiB (1,365 Gaussians and 16,384 tile instances per pass), frames
// of several thousand Gaussians rendered in slices against the same frames in one pass on the
// uncapped device: the same RGBA and depth bit for bit (SH degrees 1 and 3, 16-bit keys, depth
// off, a gradient sky, 100 km from the origin, a frame sliced for its tile instances alone,
// every Gaussian behind the camera), any slicing of one frame the same image, an image over one
// binding rendered in bands of tile rows (bit for bit too), and a key shared by more
// Gaussians than a pass refused by name.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "splat/depth_slices.h"
#include "splat/rasterizer_cpu.h"
#include "splat/rasterizer_gpu.h"
#include "splat/sky.h"
#include "test_splat_util.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

using namespace icube;

namespace {

splat::SliceHistogram histogram(uint32_t lo, uint32_t hi, uint32_t shift, std::vector<splat::SliceBucket> b) {
  splat::SliceHistogram h;
  h.key_lo = lo;
  h.key_hi = hi;
  h.shift = shift;
  h.buckets = std::move(b);
  return h;
}

// Bitwise equality of two float images, printing the first mismatches.
size_t mismatches(const std::vector<float>& got, const std::vector<float>& want, const char* what) {
  REQUIRE(got.size() == want.size());
  size_t bad = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    if (std::memcmp(&got[i], &want[i], sizeof(float)) == 0) continue;
    if (bad < 5) MESSAGE(what << "[" << i << "]: sliced " << got[i] << ", one pass " << want[i]);
    ++bad;
  }
  return bad;
}

// 64 KiB bindings: 65536 / 48 = 1365 Gaussians and 16,384 tile instances per pass.
constexpr uint64_t kCap = 64u << 10;

gpu::Context& capped_context() {
  static std::unique_ptr<gpu::Context> ctx = [] {
    gpu::ContextOptions opts = gpu::ContextOptions::from_env();
    opts.max_storage_binding = kCap;
    return test::make_validated_context(opts);
  }();
  return *ctx;
}

struct SliceRun {
  splat::SplatImage sliced, whole;
  splat::SplatTimings t_sliced, t_whole;
};

SliceRun render_both(const splat::GaussianCloud& cloud, const render::Camera& cam, const splat::SplatOptions& o) {
  SliceRun r;
  splat::SplatRendererGpu capped(capped_context());
  splat::SplatRendererGpu whole(test::gpu_context());
  r.sliced = capped.render(capped.upload(cloud), cam, o, &r.t_sliced);
  r.whole = whole.render(whole.upload(cloud), cam, o, &r.t_whole);
  CHECK(r.t_whole.slices == 0);
  return r;
}

void check_same(const SliceRun& r, const splat::SplatOptions& o) {
  CHECK(mismatches(r.sliced.rgba, r.whole.rgba, "rgba") == 0);
  if (o.depth) CHECK(mismatches(r.sliced.depth, r.whole.depth, "depth") == 0);
  CHECK(r.sliced.depth.size() == r.whole.depth.size());
  CHECK(r.t_sliced.instances == r.t_whole.instances);
}

}  // namespace

TEST_CASE("depth slices: the planner cuts keys under both limits, in key order") {
  auto no_refine = [](uint32_t, uint32_t) -> splat::SliceHistogram {
    FAIL("no refinement expected");
    return {};
  };
  // Buckets of 16 keys each from key 100: counts 3, 0, 4, 2, 6 (tiles 10 each but the empty one).
  const auto h = histogram(100, 100 + 5 * 16 - 1, 4, {{3, 10}, {0, 0}, {4, 10}, {2, 10}, {6, 10}});
  const auto s = splat::plan_depth_slices(h, 7, 1000, no_refine);
  REQUIRE(s.size() == 3);
  CHECK(s[0].key_lo == 100);
  CHECK(s[0].key_hi == 100 + 3 * 16 - 1);  // buckets 0..2 (the empty one inside)
  CHECK(s[0].gaussians == 7);
  CHECK(s[1].key_lo == 100 + 3 * 16);
  CHECK(s[1].gaussians == 2);
  CHECK(s[2].key_lo == 100 + 4 * 16);
  CHECK(s[2].key_hi == 100 + 5 * 16 - 1);
  CHECK(s[2].gaussians == 6);
  // The tile limit alone cuts too.
  const auto t = splat::plan_depth_slices(h, 100, 20, no_refine);
  REQUIRE(t.size() == 2);
  CHECK(t[0].tiles == 20);
  CHECK(t[1].gaussians == 8);
  // Nothing visible: no slice.
  CHECK(splat::plan_depth_slices(histogram(0, 255, 0, std::vector<splat::SliceBucket>(256)), 5, 5, no_refine).empty());
  CHECK_THROWS_AS(splat::plan_depth_slices(h, 0, 5, no_refine), std::invalid_argument);
}

TEST_CASE("depth slices: an over-full bucket is refined; a key shared by more Gaussians than a pass is refused") {
  int refined = 0;
  auto refine = [&](uint32_t lo, uint32_t hi) {
    ++refined;
    CHECK(lo == 256);
    CHECK(hi == 511);
    std::vector<splat::SliceBucket> b(256);
    b[3] = {4, 1};
    b[200] = {5, 1};
    return histogram(lo, hi, 0, b);
  };
  const auto h = histogram(0, 1023, 8, {{2, 1}, {9, 2}, {1, 1}, {0, 0}});
  const auto s = splat::plan_depth_slices(h, 6, 100, refine);
  CHECK(refined == 1);
  REQUIRE(s.size() == 2);
  CHECK(s[0].key_lo == 0);
  CHECK(s[0].key_hi == 256 + 3);  // bucket 0, then key 259 of the refined bucket
  CHECK(s[0].gaussians == 6);
  CHECK(s[1].key_lo == 256 + 200);
  CHECK(s[1].key_hi == 767);  // key 456 and bucket 2
  CHECK(s[1].gaussians == 6);
  CHECK_THROWS_WITH(splat::plan_depth_slices(histogram(7, 7, 0, {{9, 9}}), 6, 100, refine),
                    doctest::Contains("9 Gaussians (9 tiles) share one depth sort key (7)"));
}

TEST_CASE("depth slices gpu, kernel by kernel: slice_keys, slice_histogram, slice_flags + scan + slice_gather "
          "against their CPU references") {
  gpu::Context& ctx = test::gpu_context();
  const render::Camera cam = test::look_at_camera({0.0, -9.0, 1.5}, {0.0, 0.0, 0.0}, 61, 47, 55.0, 1.5, -2.0);
  // Many Gaussians behind the camera or outside the view (culled), odd count, SH 2 (a 28-float SH stride).
  const splat::GaussianCloud cloud = test::random_cloud(9, 2003, 2, glm::dvec3(0.0, -4.0, 0.0), 6.0, -4.0, -1.5);
  splat::SplatRendererGpu r(ctx);
  const splat::GpuGaussians g = r.upload(cloud);
  const splat::SplatOptions o;
  const splat::SplatFrame frame = splat::make_frame(cam, o, g.origin);
  splat::DepthSlicer slicer(ctx);
  const std::vector<splat::DepthSlice> slices = slicer.plan(g, frame, 32, 150, uint64_t{1} << 40);
  std::vector<uint32_t> keys, tiles, ck, ct;
  slicer.download_keys(keys, tiles);
  // splat_slice_keys against slice_keys_cpu (preprocess_cpu's projections): the same culling and
  // rect areas but where a radius lands on a float-rounding step, keys within 1e-5 of the depth.
  splat::slice_keys_cpu(splat::preprocess_cpu(cloud, cam, o), frame.grid_x, frame.grid_y, 32, ck, ct);
  REQUIRE(keys.size() == ck.size());
  size_t culled = 0, key_bad = 0, tile_diff = 0;
  for (size_t i = 0; i < keys.size(); ++i) {
    culled += keys[i] == SPLAT_SLICE_CULLED;
    if ((keys[i] == SPLAT_SLICE_CULLED) != (ck[i] == SPLAT_SLICE_CULLED)) {
      if (++key_bad <= 5) MESSAGE("Gaussian " << i << ": GPU key " << keys[i] << ", CPU key " << ck[i]);
      continue;
    }
    if (keys[i] == SPLAT_SLICE_CULLED) continue;
    float zg, zc;
    std::memcpy(&zg, &keys[i], 4);
    std::memcpy(&zc, &ck[i], 4);
    if (std::fabs(zg - zc) > 1e-5f * zc && ++key_bad <= 5) MESSAGE("Gaussian " << i << ": GPU depth " << zg << ", CPU " << zc);
    tile_diff += tiles[i] != ct[i];
  }
  CHECK(culled > 100);
  CHECK(culled < keys.size() * 3 / 4);
  CHECK(key_bad == 0);
  CHECK(tile_diff <= keys.size() / 200);
  // splat_slice_histogram through the plan: every slice holds what the CPU histogram of the GPU's
  // keys puts in its key range, the slices in key order, disjoint, each within the limit.
  const splat::SliceHistogram h = splat::slice_histogram_cpu(keys, tiles, 0, SPLAT_SLICE_CULLED - 1, 16);
  uint64_t visible = 0;
  for (const splat::SliceBucket& b : h.buckets) visible += b.gaussians;
  CHECK(visible == keys.size() - culled);
  REQUIRE(slices.size() >= 4);
  uint64_t covered = 0;
  for (size_t k = 0; k < slices.size(); ++k) {
    CAPTURE(k);
    const splat::DepthSlice& sl = slices[k];
    if (k > 0) CHECK(sl.key_lo > slices[k - 1].key_hi);
    const splat::SliceHistogram in = splat::slice_histogram_cpu(keys, tiles, sl.key_lo, sl.key_hi, 31);
    CHECK(in.buckets[0].gaussians == sl.gaussians);
    CHECK(in.buckets[0].tiles == sl.tiles);
    CHECK(sl.gaussians <= 150);
    covered += sl.gaussians;
  }
  CHECK(covered == visible);
  // splat_slice_flags + PrefixScan + splat_slice_gather: each slice's rows and SH rows are the
  // input's rows of its members (slice_members_cpu), in index order, bit for bit.
  std::vector<shader::SplatGaussian> rows;
  std::vector<float> sh;
  splat::pack_gaussians(cloud, g.origin, g.sh_stride, rows, sh);
  splat::GpuGaussians out;
  for (const splat::DepthSlice& sl : slices) {
    slicer.gather(g, sl, out);
    const std::vector<uint32_t> members = splat::slice_members_cpu(keys, sl);
    REQUIRE(out.count == members.size());
    const auto got_rows = gpu::download_vector<shader::SplatGaussian>(ctx, out.gaussians, out.count);
    const auto got_sh = gpu::download_vector<float>(ctx, out.sh, size_t{out.count} * g.sh_stride);
    size_t bad = 0;
    for (size_t j = 0; j < members.size(); ++j) {
      const bool row_ok = std::memcmp(&got_rows[j], &rows[members[j]], sizeof(shader::SplatGaussian)) == 0;
      const bool sh_ok = std::memcmp(&got_sh[j * g.sh_stride], &sh[size_t{members[j]} * g.sh_stride], g.sh_stride * 4) == 0;
      if ((!row_ok || !sh_ok) && ++bad <= 5) MESSAGE("slice place " << j << " (Gaussian " << members[j] << ") differs");
    }
    CHECK(bad == 0);
  }
}

TEST_CASE("depth slices gpu: frames over one pass (64 KiB bindings) equal one pass bit for bit") {
  splat::SplatRendererGpu probe(capped_context());
  REQUIRE(probe.gaussians_per_pass() == kCap / 48);
  REQUIRE(probe.instances_per_pass() == kCap / 4);
  const render::Camera cam = test::look_at_camera({0.0, -9.0, 1.5}, {0.0, 0.0, 0.0}, 61, 47, 55.0, 1.5, -2.0);
  for (const uint32_t degree : {1u, 3u}) {
    CAPTURE(degree);
    const splat::GaussianCloud cloud = test::random_cloud(11 + degree, 5003, degree, glm::dvec3(0.0), 3.0, -4.0, -1.5);
    splat::SplatOptions o;
    const SliceRun r = render_both(cloud, cam, o);
    MESSAGE("SH " << degree << ": " << r.t_sliced.slices << " slices, " << r.t_sliced.instances << " instances");
    CHECK(r.t_sliced.slices >= 4);
    check_same(r, o);
  }
  const splat::GaussianCloud cloud = test::random_cloud(5, 4001, 1, glm::dvec3(0.0), 3.0, -4.0, -1.5);
  SUBCASE("16-bit depth keys") {
    splat::SplatOptions o;
    o.depth_key_bits = 16;
    const SliceRun r = render_both(cloud, cam, o);
    CHECK(r.t_sliced.slices >= 3);
    check_same(r, o);
  }
  SUBCASE("no depth outputs, a gradient sky") {
    splat::SplatOptions o;
    o.depth = false;
    o.sky = splat::sky_gradient();
    const SliceRun r = render_both(cloud, cam, o);
    CHECK(r.t_sliced.slices >= 3);
    check_same(r, o);
  }
  SUBCASE("100 km from the origin") {
    splat::GaussianCloud far = cloud;
    const glm::dvec3 shift(1e5, -7e4, 30.0);
    for (auto& p : far.positions) p += shift;
    render::Camera c = cam;
    c.c2w[3] += glm::dvec4(shift, 0.0);
    splat::SplatOptions o;
    const SliceRun r = render_both(far, c, o);
    CHECK(r.t_sliced.slices >= 3);
    check_same(r, o);
  }
  SUBCASE("every Gaussian behind the camera: the background alone") {
    render::Camera away = test::look_at_camera({0.0, -9.0, 1.5}, {0.0, -20.0, 1.5}, 61, 47, 55.0);
    splat::SplatOptions o;
    o.background = {0.25f, 0.5f, 0.75f};
    const SliceRun r = render_both(cloud, away, o);
    CHECK(r.t_sliced.slices == 0);
    check_same(r, o);
    CHECK(r.sliced.rgba[0] == 0.25f);
    CHECK(r.sliced.rgba[3] == 0.0f);
  }
}

TEST_CASE("depth slices gpu: any slicing of a frame (SplatGpuVariant::max_pass_gaussians) gives the same image") {
  const render::Camera cam = test::look_at_camera({1.0, -8.0, 2.5}, {0.0, 0.0, 0.0}, 83, 45, 60.0);
  const splat::GaussianCloud cloud = test::random_cloud(3, 3001, 2, glm::dvec3(0.0), 3.0, -4.0, -1.0);
  splat::SplatRendererGpu whole(test::gpu_context());
  splat::SplatTimings tw;
  const splat::SplatImage want = whole.render(whole.upload(cloud), cam, splat::SplatOptions{}, &tw);
  for (const uint64_t per_pass : {500ull, 1499ull, 2999ull}) {
    CAPTURE(per_pass);
    splat::SplatGpuVariant v;
    v.max_pass_gaussians = per_pass;
    splat::SplatRendererGpu r(test::gpu_context(), v);
    splat::SplatTimings t;
    const splat::SplatImage got = r.render(r.upload(cloud), cam, splat::SplatOptions{}, &t);
    CHECK(t.slices >= (per_pass < 2000 ? 2u : 1u));
    CHECK(t.instances == tw.instances);
    CHECK(mismatches(got.rgba, want.rgba, "rgba") == 0);
    CHECK(mismatches(got.depth, want.depth, "depth") == 0);
  }
}

TEST_CASE("depth slices gpu: a frame of few Gaussians with more tile instances than a pass is sliced too") {
  // 1300 Gaussians (under 1365) of 0.5-1 m at 4-6 m cover most of the 16 tiles of a 64x64 image
  // (the largest image a 64 KiB binding holds): more than 16,384 instances.
  const render::Camera cam = test::look_at_camera({0.0, -5.0, 0.0}, {0.0, 0.0, 0.0}, 64, 64, 160.0);
  const splat::GaussianCloud cloud = test::random_cloud(21, 1300, 0, glm::dvec3(0.0), 1.0, -0.7, 0.0);
  splat::SplatOptions o;
  const SliceRun r = render_both(cloud, cam, o);
  MESSAGE(r.t_whole.instances << " tile instances in " << r.t_sliced.slices << " slices");
  CHECK(r.t_whole.instances > kCap / 4);
  CHECK(r.t_sliced.slices >= 2);
  check_same(r, o);
}

TEST_CASE("depth slices gpu: an image over one binding is rendered in bands of tile rows") {
  // 100 x 90 px = 144,000 bytes of RGBA floats: bands of 32 rows (the last 26), sliced too.
  const render::Camera cam = test::look_at_camera({0.0, -9.0, 1.5}, {0.0, 0.0, 0.0}, 100, 90, 80.0, 3.5, -1.0);
  const splat::GaussianCloud cloud = test::random_cloud(17, 3001, 1, glm::dvec3(0.0), 3.0, -4.0, -1.5);
  splat::SplatOptions o;
  o.sky = splat::sky_gradient();
  const SliceRun r = render_both(cloud, cam, o);
  CHECK(r.t_sliced.bands == 3);
  CHECK(r.t_sliced.slices >= 2);
  CHECK(r.t_whole.bands == 0);
  // Each band is the whole image's frame with its tile rects clipped to the band's rows: the same
  // projection, the same per-tile lists, the same pixels bit for bit, and the bands' tile
  // instances add up to the whole image's.
  check_same(r, o);
  splat::SplatRendererGpu capped(capped_context());
  CHECK_THROWS_WITH(capped.render(capped.upload(cloud), cam, o, nullptr, nullptr, false),
                    doctest::Contains("is rendered in bands: download it"));
  render::Camera wide = cam;
  wide.K.width = 300;  // 300 x 16 px x 16 B > 64 KiB: not even one tile row fits
  CHECK_THROWS_WITH(capped.render(capped.upload(cloud), wide, o), doctest::Contains("render at most 256 pixels wide"));
}

TEST_CASE("depth slices gpu: more Gaussians at one depth than a pass takes are refused by name") {
  splat::GaussianCloud c;
  c.sh_degree = 0;
  const float dc[3] = {0.5f, 0.5f, 0.5f};
  for (int i = 0; i < 1500; ++i) c.add({0.0, 0.0, 0.0}, glm::vec3(0.05f), glm::vec4(1, 0, 0, 0), 0.5f, dc);
  const render::Camera cam = test::look_at_camera({0.0, -4.0, 0.0}, {0.0, 0.0, 0.0}, 32, 32, 40.0);
  splat::SplatRendererGpu capped(capped_context());
  CHECK_THROWS_WITH(capped.render(capped.upload(c), cam, splat::SplatOptions{}),
                    doctest::Contains("1500 Gaussians (6000 tiles) share one depth sort key"));
}
