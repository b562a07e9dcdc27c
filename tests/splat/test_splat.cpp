// The Gaussian splatting rasterizer: the GPU path (engine/splat/rasterizer_gpu.h,
// shaders/splat/*.comp) against the CPU reference (rasterizer_cpu.h) on
// fixed-seed random scenes (SH 0–3, odd image sizes, off-centre principal
// points, antialiased mode) and on the real .ply in ../shared/data/splats:
// identical tile-intersection lists (exact tile culling, and whole rects for
// the whole-rect variant) and ranges, projected means/conics/depths
// within 1e-4, RGBA and expected depth within 1e-3 at every pixel, median
// depth within 1e-3 except a bounded boundary band (lavapipe's exp2 differs from
// libm's exp in the last bits, which can move the T = 0.5 crossing to another
// Gaussian: there the median must be 0 or another binned Gaussian's depth); a
// scene translated by 100 km renders the same; degenerate
// Gaussians (huge/tiny scales, opacity 0 and 1, straddling the near plane,
// screen edges); CPU reference against hand-computed values; exact tile
// culling drops only tiles no pixel needs (bit-identical images, fewer
// instances); all four SplatGpuVariant pipelines; both tile-binning paths (the counting sort
// of tile_binning_gpu.h with 1, odd and many chunks, and the radix path) give
// the CPU's lists and ranges, incl. an empty scene and one tile getting every
// instance. The comparison: splat_compare.h; sky models: test_splat_sky.cpp;
// the stage API: test_splat_stages.cpp.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/png_write.h"
#include "splat/rasterizer_cpu.h"
#include "splat/rasterizer_gpu.h"
#include "splat/sky.h"
#include "splat_compare.h"
#include "test_splat_util.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

using namespace icube;
using splat::SplatOptions;

using namespace icube::test;


TEST_CASE("splat cpu: one isotropic Gaussian matches hand-computed values") {
  splat::GaussianCloud c;
  c.sh_degree = 0;
  const float dc[3] = {static_cast<float>(0.5 / splat::kShC0), 0.0f, static_cast<float>(-0.5 / splat::kShC0)};
  c.add({0.0, 0.0, 5.0}, glm::vec3(0.1f), glm::vec4(1, 0, 0, 0), 0.8f, dc);
  render::Camera cam;
  cam.K = {100.0, 100.0, 32.0, 32.0, 64, 64};
  SplatOptions o;
  const auto proj = splat::preprocess_cpu(c, cam, o);
  const auto& g = proj[0];
  CHECK(g.mean_x == doctest::Approx(32.0));
  CHECK(g.depth == doctest::Approx(5.0));
  // σ₂² = (f σ / z)² = 4 px², + 0.3
  CHECK(g.conic_x == doctest::Approx(1.0 / 4.3).epsilon(1e-5));
  CHECK(g.conic_y == doctest::Approx(0.0));
  CHECK(g.radius == std::ceil(3.0f * std::sqrt(4.3f)));
  CHECK(g.r == doctest::Approx(1.0));
  CHECK(g.b == doctest::Approx(0.0));
  o.background = {0.0f, 0.0f, 1.0f};
  const auto img = splat::render_cpu(c, cam, o);
  // pixel (31, 31) is sampled at (31.5, 31.5): power = -0.5·(0.25+0.25)/4.3
  const size_t p = 31 * 64 + 31;
  const double a = 0.8 * std::exp(-0.25 / 4.3);
  CHECK(img.rgba[4 * p + 0] == doctest::Approx(a).epsilon(1e-5));
  CHECK(img.rgba[4 * p + 2] == doctest::Approx(1.0 - a).epsilon(1e-5));
  CHECK(img.rgba[4 * p + 3] == doctest::Approx(a).epsilon(1e-5));
  CHECK(img.depth[2 * p] == doctest::Approx(5.0));
  CHECK(img.depth[2 * p + 1] == doctest::Approx(5.0));  // alpha 0.77 > 0.5
  // antialiased: compensation sqrt(det(Σ)/det(Σ + 0.3 I)) = 4/4.3
  o.antialiased = true;
  CHECK(splat::preprocess_cpu(c, cam, o)[0].opacity == doctest::Approx(0.8 * 4.0 / 4.3).epsilon(1e-5));
  // behind the near plane / beyond far
  o.near_z = 5.5;
  CHECK(splat::preprocess_cpu(c, cam, o)[0].radius == 0.0f);
  o.near_z = 0.01;
  o.far_z = 4.0;
  CHECK(splat::preprocess_cpu(c, cam, o)[0].radius == 0.0f);
}

TEST_CASE("splat cpu: exact tile culling drops only tiles that no pixel needs (image equals whole-rect binning)") {
  // Random scenes incl. strongly anisotropic Gaussians (scales e^-6..e^0 per axis), both pixel
  // conventions, antialiased opacity and off-centre principal points: binning by the α-cut
  // ellipse (TileRule::Ellipse) must give bit-identical pixels to binning whole getRect rects
  // (TileRule::Rect), a subset of its instances, and clearly fewer of them.
  struct Case {
    uint32_t seed;
    size_t n;
    uint32_t w, h;
    double lo, hi, cx_off;
    bool aa;
  };
  const Case cases[] = {{11, 3000, 161, 97, -4.0, -1.0, 0.0, false},
                        {12, 3000, 130, 130, -6.0, 0.0, 9.5, true},
                        {13, 500, 64, 300, -5.0, -0.5, -20.0, false}};
  for (const Case& k : cases) {
    CAPTURE(k.seed);
    const auto cloud = test::random_cloud(k.seed, k.n, 1, {0.0, 0.0, 0.0}, 2.0, k.lo, k.hi);
    const auto cam = test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, k.w, k.h, 0.9 * k.w, k.cx_off, 0.3 * k.cx_off);
    SplatOptions o;
    o.antialiased = k.aa;
    o.background = {0.2f, 0.3f, 0.4f};
    o.pixels = k.seed % 2 ? render::PixelConvention::Centre : render::PixelConvention::Integer;
    const auto proj = splat::preprocess_cpu(cloud, cam, o);
    const auto f = splat::make_frame(cam, o, glm::dvec3(0.0));
    const auto ell = splat::bin_cpu(proj, f.grid_x, f.grid_y, splat::TileRule::Ellipse);
    const auto rect = splat::bin_cpu(proj, f.grid_x, f.grid_y, splat::TileRule::Rect);
    // subset: every (tile, Gaussian) pair of the ellipse rule is in the rect rule's list
    size_t missing = 0, j = 0;
    for (size_t i = 0; i < ell.keys.size(); ++i) {
      while (j < rect.keys.size() && (rect.keys[j] != ell.keys[i] || rect.values[j] != ell.values[i])) ++j;
      if (j == rect.keys.size()) ++missing;
    }
    CHECK(missing == 0);
    size_t counted = 0;
    for (const auto& g : proj) counted += splat::tile_count(g, f.grid_x, f.grid_y);
    CHECK(counted == ell.keys.size());
    MESSAGE("seed " << k.seed << ": " << ell.keys.size() << " instances with exact culling, " << rect.keys.size()
                    << " with whole rects");
    CHECK(double(ell.keys.size()) < 0.9 * double(rect.keys.size()));
    const auto a = splat::blend_cpu(proj, ell, cam, o);
    const auto b = splat::blend_cpu(proj, rect, cam, o);
    CHECK(test::equal_report(a.rgba, b.rgba, "rgba"));
    CHECK(test::equal_report(a.depth, b.depth, "depth"));
  }
}

TEST_CASE("splat gpu vs cpu, stage by stage (splat_preprocess, splat_sorted_counts, splat_duplicate + sort, splat_ranges, splat_blend; splat_blend_rows in the variants): random scenes" * doctest::test_suite("subgroup-sensitive")) {
  Renderer R;
  struct Case {
    uint32_t seed, degree;
    size_t n;
    uint32_t w, h;
    double cx_off;
    bool aa;
  };
  const Case cases[] = {{1, 0, 1, 64, 48, 0.0, false},      {2, 1, 13, 33, 17, 3.5, false},
                        {3, 2, 500, 127, 95, -7.25, true},  {4, 3, 2000, 160, 120, 0.0, false},
                        {5, 3, 20000, 256, 192, 11.0, true}};
  for (const Case& k : cases) {
    CAPTURE(k.seed);
    const auto cloud = test::random_cloud(k.seed, k.n, k.degree, {0.0, 0.0, 0.0}, 2.0);
    const auto cam = test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, k.w, k.h, 0.9 * k.w, k.cx_off, -0.5 * k.cx_off);
    SplatOptions o;
    o.antialiased = k.aa;
    o.background = {0.2f, 0.3f, 0.4f};
    o.pixels = k.seed % 2 ? render::PixelConvention::Centre : render::PixelConvention::Integer;
    char what[64];
    std::snprintf(what, sizeof what, "random seed %u (%zu Gaussians, SH%u, %ux%u)", k.seed, k.n, k.degree, k.w, k.h);
    report(what, compare(R.r, cloud, cam, o));
  }
  // The other pipeline variants (whole-rect binning, the previous row blend splat_blend_rows) on one scene.
  const auto cloud = test::random_cloud(6, 5000, 3, {0.0, 0.0, 0.0}, 2.0);
  const auto cam = test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, 150, 101, 140.0, 4.5, -2.0);
  SplatOptions o;
  o.background = {0.2f, 0.3f, 0.4f};
  for (const bool cull : {false, true})
    for (const bool tile_blend : {false, true}) {
      CAPTURE(cull);
      CAPTURE(tile_blend);
      splat::SplatRendererGpu v(test::gpu_context(), splat::SplatGpuVariant{cull, tile_blend});
      report(std::string("variant cull ") + (cull ? "on" : "off") + ", " + (tile_blend ? "tile" : "row") + " blend",
             compare(v, cloud, cam, o, 0.002, cull ? splat::TileRule::Ellipse : splat::TileRule::Rect));
    }
  // splat_blend's two vote paths (subgroup intrinsics on GPUs, constant-index shuffles on CPU
  // devices), each forced on this device: the same images.
  using Votes = kernels::SubgroupOps;
  std::vector<splat::SplatImage> images;
  for (const Votes votes : {Votes::Intrinsics, Votes::Shuffles}) {
    CAPTURE(static_cast<int>(votes));
    const uint32_t sg = test::gpu_context().subgroup_size();
    if (votes == Votes::Shuffles && (sg > 16 || 16 % sg != 0)) continue;
    splat::SplatGpuVariant vv;
    vv.votes = votes;
    splat::SplatRendererGpu v(test::gpu_context(), vv);
    report(votes == Votes::Intrinsics ? "blend votes by subgroup intrinsics" : "blend votes by shuffles",
           compare(v, cloud, cam, o));
    images.push_back(v.render(v.upload(cloud), cam, o));
  }
  if (images.size() == 2) {
    CHECK(images[0].rgba == images[1].rgba);
    CHECK(images[0].depth == images[1].depth);
  }
}

// SplatOptions::depth = false: splat_blend's pipeline without the depth outputs (SPLAT_DEPTH = 0)
// blends the same colours and alpha bit for bit and returns no depth; so does the CPU reference.
TEST_CASE("splat: 16-bit depth keys (SplatOptions::depth_key_bits = 16): the code, GPU vs CPU, close to the exact order") {
  // The key: monotonic, 2048 steps per octave, 0 for culled / tiny depths, clamped at 2^16 m.
  CHECK(splat::depth_key16(0.0f) == 0);
  CHECK(splat::depth_key16(std::ldexp(1.0f, -16)) == 0);
  CHECK(splat::depth_key16(std::ldexp(1.0f, -15)) == 2048);
  CHECK(splat::depth_key16(1.0f) == 16 * 2048);
  CHECK(splat::depth_key16(1.0f + std::ldexp(1.0f, -11)) == 16 * 2048 + 1);
  CHECK(splat::depth_key16(1.0f + std::ldexp(1.0f, -12)) == 16 * 2048);  // within one step
  CHECK(splat::depth_key16(65535.9f) == 65535);
  CHECK(splat::depth_key16(1e30f) == 65535);
  CHECK(splat::depth_key16(-1.0f) == 65535);
  uint32_t prev = 0;
  for (float z = 1e-6f; z < 1e6f; z *= 1.0007f) {
    const uint32_t k = splat::depth_key16(z);
    REQUIRE(k >= prev);
    prev = k;
  }
  SplatOptions bad;
  bad.depth_key_bits = 24;
  CHECK_THROWS_AS(splat::make_frame(test::look_at_camera({0, -5, 0}, {0, 0, 0}, 32, 32, 30.0), bad, glm::dvec3(0.0)),
                  std::invalid_argument);

  // GPU vs CPU stage by stage with 16-bit keys (a 2-pass depth sort), and the image against the exact order's.
  Renderer R;
  for (const uint32_t seed : {7u, 8u}) {
    CAPTURE(seed);
    const auto cloud = test::random_cloud(seed, seed == 7 ? 3000 : 20000, 1, {0.0, 0.0, 0.0}, 2.0);
    const auto cam = test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, 161, 97, 150.0, 2.5, -1.0);
    SplatOptions o;
    o.background = {0.2f, 0.3f, 0.4f};
    o.depth_key_bits = 16;
    report(seed == 7 ? "16-bit keys, 3000 Gaussians" : "16-bit keys, 20000 Gaussians", compare(R.r, cloud, cam, o));
    const splat::GpuGaussians g = R.r.upload(cloud);
    const splat::SplatImage k16 = R.r.render(g, cam, o);
    o.depth_key_bits = 32;
    const splat::SplatImage k32 = R.r.render(g, cam, o);
    double se = 0.0;
    for (size_t i = 0; i < k16.rgba.size(); ++i) se += double(k16.rgba[i] - k32.rgba[i]) * double(k16.rgba[i] - k32.rgba[i]);
    const double psnr = se > 0.0 ? -10.0 * std::log10(se / double(k16.rgba.size())) : 99.0;
    // A dense random 4 m cloud: many Gaussians within one step (3 mm at 6 m) of each other.
    INFO("16-bit vs 32-bit keys: PSNR " << psnr << " dB");
    CHECK(psnr > 38.0);
  }
}

TEST_CASE("splat gpu: colour-only frames (SplatOptions::depth = false, splat_blend without depth) equal the full blend" * doctest::test_suite("subgroup-sensitive")) {
  Renderer R;
  const auto cloud = test::random_cloud(21, 4000, 3, {0.0, 0.0, 0.0}, 2.0);
  const auto cam = test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, 157, 93, 140.0, 3.5, -1.0);
  const auto g = R.r.upload(cloud);
  for (const auto conv : {render::PixelConvention::Centre, render::PixelConvention::Integer}) {
    CAPTURE(int(conv));
    SplatOptions full;
    full.pixels = conv;
    full.background = {0.2f, 0.3f, 0.4f};
    SplatOptions color = full;
    color.depth = false;
    const auto a = R.r.render(g, cam, full);
    const auto b = R.r.render(g, cam, color);
    const auto c = R.r.render(g, cam, full);  // switching back: the depth pipeline again
    REQUIRE(a.rgba.size() == size_t{157} * 93 * 4);
    CHECK(a.depth.size() == size_t{157} * 93 * 2);
    CHECK(b.depth.empty());
    CHECK(b.rgba == a.rgba);
    CHECK(c.rgba == a.rgba);
    CHECK(c.depth == a.depth);
    size_t covered = 0;
    for (size_t p = 0; p < a.rgba.size() / 4; ++p) covered += a.rgba[4 * p + 3] > 0.5f;
    CHECK(covered > 1000);  // the scene covers much of the frame
    const auto cpu = splat::render_cpu(cloud, cam, color);
    CHECK(cpu.depth.empty());
    CHECK(cpu.rgba.size() == a.rgba.size());
  }
}

TEST_CASE("splat gpu binning: the counting sort (splat_bin_chunks, splat_bin_offsets; 1, few, odd and many chunks) and the radix path give the CPU's tile lists and ranges") {
  using splat::SplatGpuVariant;
  using splat::TileBinning;
  {
    splat::SplatRendererGpu autod(test::gpu_context());
    const bool cpu_device = test::gpu_context().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
    CHECK((autod.binning() == TileBinning::Counting) == cpu_device);
    CHECK(splat::SplatRendererGpu(test::gpu_context(), SplatGpuVariant{true, true, TileBinning::Radix}).binning() ==
          TileBinning::Radix);
  }
  {  // chunks_for: whole subgroups, kChunkGroupsPerThread per device thread (at least kMinChunkGroups),
     // at most kMaxInstancesPerChunk each
    const splat::TileBinningGpu b(test::gpu_context());
    const uint32_t sg = test::gpu_context().subgroup_size();
    using B = splat::TileBinningGpu;
    CHECK(B::chunk_groups(1) == 2);
    CHECK(B::chunk_groups(2) == 4);
    CHECK(B::chunk_groups(16) == 32);
    CHECK(B::device_threads() >= 1);
    const uint64_t least = B::chunk_groups(B::device_threads()) * sg;
    CHECK(b.chunks_for(1, 3600) == least);
    const uint64_t need = std::max<uint64_t>(least, (778680 + B::kMaxInstancesPerChunk - 1) / B::kMaxInstancesPerChunk);
    CHECK(b.chunks_for(778680, 3600) == (need + sg - 1) / sg * sg);
    const uint32_t big = b.chunks_for(13776864, 8160);  // 1M Gaussians at 1080p
    CHECK(big % sg == 0);
    CHECK(uint64_t{big} * B::kMaxInstancesPerChunk >= 13776864);
    CHECK(uint64_t{big} * 8160 * 4 <= test::gpu_context().info().max_storage_buffer_range);
    CHECK(b.chunks_for(100, 3600, 37) == 37);
    CHECK(b.chunks_for(100, 3600, uint32_t(B::kMaxChunks) + 1) == 0);  // too many: the radix path bins
  }
  // (binning, forced chunk count): 0 = chunks_for's choice; 1 chunk walks everything in one
  // invocation; 37 is no multiple of any subgroup size; 4096 leaves most chunks empty.
  const std::pair<TileBinning, uint32_t> paths[] = {
      {TileBinning::Radix, 0}, {TileBinning::Counting, 0}, {TileBinning::Counting, 1},
      {TileBinning::Counting, 37}, {TileBinning::Counting, 4096}};
  struct Scene {
    std::string what;
    splat::GaussianCloud cloud;
    render::Camera cam;
  };
  std::vector<Scene> scenes;
  scenes.push_back({"random, 3000 Gaussians, 203x77", test::random_cloud(11, 3000, 1, {0.0, 0.0, 0.0}, 2.0),
                    test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, 203, 77, 150.0, 5.5, -3.0)});
  scenes.push_back({"random, 13 Gaussians, 33x17", test::random_cloud(12, 13, 0, {0.0, 0.0, 0.0}, 2.0),
                    test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, 33, 17, 30.0)});
  // 400 small Gaussians within 1 cm of the optical axis at 5 m: every instance in one tile
  // (image 64x48, the principal point at the centre of tile (2, 1)).
  scenes.push_back({"one tile gets every instance", test::random_cloud(13, 400, 0, {0.0, 0.0, 0.0}, 0.01, -6.0, -5.0),
                    test::look_at_camera({0.0, -5.0, 0.0}, {0.0, 0.0, 0.0}, 64, 48, 60.0, 8.0, 0.0)});
  scenes.push_back({"empty scene", splat::GaussianCloud{},
                    test::look_at_camera({0.0, -5.0, 0.0}, {0.0, 0.0, 0.0}, 40, 20, 30.0)});
  for (const Scene& sc : scenes) {
    CAPTURE(sc.what);
    SplatOptions o;
    o.background = {0.2f, 0.3f, 0.4f};
    for (const bool cull : {true, false})
      for (const auto& [binning, chunks] : paths) {
        CAPTURE(cull);
        CAPTURE(static_cast<int>(binning));
        CAPTURE(chunks);
        splat::SplatRendererGpu r(test::gpu_context(), SplatGpuVariant{cull, true, binning, chunks});
        REQUIRE(r.binning() == binning);
        const Compare c = compare(r, sc.cloud, sc.cam, o, 0.002, cull ? splat::TileRule::Ellipse : splat::TileRule::Rect);
        if (sc.what == "one tile gets every instance" && cull) {
          // the scene does what it says: every instance in the principal point's tile
          const auto proj = splat::preprocess_cpu(sc.cloud, sc.cam, o);
          const auto f = splat::make_frame(sc.cam, o, glm::dvec3(0.0));
          const auto bins = splat::bin_cpu(proj, f.grid_x, f.grid_y, splat::TileRule::Ellipse);
          CHECK(bins.keys.size() >= 300);
          CHECK(bins.ranges[2 * (f.grid_x + 2) + 1] - bins.ranges[2 * (f.grid_x + 2)] == bins.keys.size());
        }
        if (binning == TileBinning::Counting && chunks == 0 && cull)
          report("counting binning: " + sc.what, c);
      }
  }
  // 190k instances, counting (one chunk: more than 65,535 instances, which lavapipe's loop limit
  // cuts short, so the renderer notices and bins the frame with the radix path; and the default
  // chunks) against the radix path, bit for bit (this many Gaussians have float depth near-ties
  // that the CPU's double positions order differently, so the values are compared GPU to GPU,
  // the ranges also to the CPU).
  {
    const auto cloud = test::random_cloud(14, 20000, 0, {0.0, 0.0, 0.0}, 2.0, -3.0, -1.5);
    const auto cam = test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, 320, 240, 300.0);
    SplatOptions o;
    const auto proj = splat::preprocess_cpu(cloud, cam, o);
    const auto f = splat::make_frame(cam, o, glm::dvec3(0.0));
    const auto bins = splat::bin_cpu(proj, f.grid_x, f.grid_y, splat::TileRule::Ellipse);
    REQUIRE(bins.keys.size() > 70000);
    splat::SplatRendererGpu radix(test::gpu_context(), SplatGpuVariant{true, true, TileBinning::Radix});
    splat::SplatDebug want;
    radix.render(radix.upload(cloud), cam, o, nullptr, &want);
    CHECK(test::equal_report(want.ranges, bins.ranges, "radix ranges vs cpu"));
    for (const uint32_t chunks : {1u, 0u}) {
      CAPTURE(chunks);
      splat::SplatRendererGpu r(test::gpu_context(), SplatGpuVariant{true, true, TileBinning::Counting, chunks});
      splat::SplatDebug dbg;
      splat::SplatTimings tm;
      r.render(r.upload(cloud), cam, o, &tm, &dbg);
      CHECK(test::equal_report(dbg.values, want.values, "values"));
      CHECK(test::equal_report(dbg.ranges, want.ranges, "ranges"));
      CHECK(tm.binning_fallback == dbg.binning_fallback);
      CHECK(dbg.counting == !dbg.binning_fallback);
      if (chunks == 0) CHECK(!dbg.binning_fallback);
      if (chunks == 1 && test::gpu_context().info().driver_name.find("llvmpipe") != std::string::npos)
        CHECK(dbg.binning_fallback);
      MESSAGE(chunks << " chunks (0: default), " << bins.keys.size() << " instances: "
                     << std::string(dbg.binning_fallback ? "walk cut short, radix fallback" : "counting sort completed"));
    }
  }
}

TEST_CASE("splat gpu vs cpu, stage by stage (splat_preprocess, splat_sorted_counts, splat_duplicate + sort, splat_ranges, splat_blend): the real .ply") {
  Renderer R;
  const std::string path = test::test_data_file("splats/pc_short.ply");
  if (path.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  const auto cloud = splat::read_gaussians_ply(path);
  const auto s = splat::summarize(cloud);
  const double ext = glm::length(s.max - s.min);
  for (int view = 0; view < 3; ++view) {
    const double a = 2.1 * view;
    const glm::dvec3 eye = s.centroid + ext * glm::dvec3(std::cos(a), std::sin(a), 0.3);
    const auto cam = test::look_at_camera(eye, s.centroid, 200, 150, 180.0);
    SplatOptions o;
    report("pc_short.ply", compare(R.r, cloud, cam, o));
  }
}

TEST_CASE("splat: a scene translated by 100 km renders the same") {
  const auto cloud = test::random_cloud(7, 3000, 3, {0.0, 0.0, 0.0}, 2.0);
  auto far = cloud;
  const glm::dvec3 shift(100000.0, -70000.0, 3000.0);
  for (auto& p : far.positions) p += shift;
  const auto cam = test::look_at_camera({1.0, -6.0, 2.0}, {0.0, 0.0, 0.0}, 96, 64, 90.0);
  auto cam_far = cam;
  cam_far.c2w[3] += glm::dvec4(shift, 0.0);
  SplatOptions o;
  Renderer R;
  auto& gpu = R.r;
  const auto a = gpu.render(gpu.upload(cloud), cam, o);
  const auto b = gpu.render(gpu.upload(far), cam_far, o);
  double d = 0.0;
  for (size_t i = 0; i < a.rgba.size(); ++i) d = std::max(d, std::fabs(double(a.rgba[i]) - double(b.rgba[i])));
  MESSAGE("100 km translation: max GPU pixel difference " << d);
  CHECK(d <= 1e-3);
  const auto ca = splat::render_cpu(cloud, cam, o);
  const auto cb = splat::render_cpu(far, cam_far, o);
  double dc = 0.0;
  for (size_t i = 0; i < ca.rgba.size(); ++i) dc = std::max(dc, std::fabs(double(ca.rgba[i]) - double(cb.rgba[i])));
  MESSAGE("100 km translation: max CPU pixel difference " << dc);
  CHECK(dc <= 1e-3);
  // and the far scene on the GPU against the CPU, with both binning paths
  for (const auto binning : {splat::TileBinning::Counting, splat::TileBinning::Radix}) {
    splat::SplatRendererGpu r(test::gpu_context(), splat::SplatGpuVariant{true, true, binning});
    report(binning == splat::TileBinning::Counting ? "100 km scene, counting binning" : "100 km scene, radix binning",
           compare(r, far, cam_far, o));
  }
}

TEST_CASE("splat: degenerate Gaussians") {
  Renderer R;
  const auto cam = test::look_at_camera({0.0, -5.0, 0.0}, {0.0, 0.0, 0.0}, 80, 60, 70.0);
  const glm::dvec3 fwd(0.0, 1.0, 0.0);  // camera z in world
  splat::GaussianCloud c;
  c.sh_degree = 1;
  std::vector<float> coeffs(12, 0.1f);
  const glm::vec4 q0(1, 0, 0, 0);
  c.add({0.0, 0.0, 0.0}, glm::vec3(1e3f), q0, 0.5f, coeffs.data());              // huge: covers the screen
  c.add({0.2, 0.0, 0.1}, glm::vec3(1e-9f), q0, 0.9f, coeffs.data());             // tiny: dilation only
  c.add({0.3, 0.0, 0.0}, glm::vec3(0.1f), q0, 0.0f, coeffs.data());              // opacity 0: culled
  c.add({-0.3, 0.0, 0.0}, glm::vec3(0.1f), q0, 1.0f, coeffs.data());             // opacity 1: α capped at 0.99
  c.add(glm::dvec3(0.0, -5.0, 0.0) + 0.005 * fwd, glm::vec3(0.5f), q0, 0.7f, coeffs.data());  // centre before near
  c.add(glm::dvec3(0.0, -5.0, 0.0) + 0.02 * fwd, glm::vec3(0.5f), q0, 0.7f, coeffs.data());   // straddles near
  c.add({3.0, 0.0, 0.0}, glm::vec3(0.3f, 0.05f, 0.05f), q0, 0.8f, coeffs.data());  // right screen edge
  c.add({-3.6, 0.0, 2.5}, glm::vec3(0.2f), q0, 0.8f, coeffs.data());               // top-left corner, partly off
  c.add({40.0, 5.0, 0.0}, glm::vec3(0.2f), q0, 0.8f, coeffs.data());               // far off screen: clamp, culled
  c.add({0.0, -5.0, 0.0}, glm::vec3(0.2f), q0, 0.8f, coeffs.data());               // at the camera centre
  c.add({0.0, -6.0, 0.0}, glm::vec3(0.2f), q0, 0.8f, coeffs.data());               // behind the camera
  c.add({0.5, 1.0, -0.5}, glm::vec3(4.0f, 1e-6f, 4.0f), glm::vec4(0.7071f, 0.7071f, 0, 0), 0.6f, coeffs.data());  // flat
  SplatOptions o;
  const auto proj = splat::preprocess_cpu(c, cam, o);
  CHECK(proj[0].radius > 0.0f);
  CHECK(proj[1].radius == 3.0f);  // dilation only: mid 0.3, det 0.09, eigen guard λ = 0.3 + √0.1, ⌈3·√λ⌉ = 3
  CHECK(proj[2].radius == 0.0f);
  CHECK(proj[3].radius > 0.0f);
  CHECK(proj[4].radius == 0.0f);
  CHECK(proj[5].radius > 0.0f);
  CHECK(proj[6].radius > 0.0f);
  CHECK(proj[8].radius == 0.0f);
  CHECK(proj[9].radius == 0.0f);
  CHECK(proj[10].radius == 0.0f);
  for (const auto& g : proj) CHECK(std::isfinite(g.mean_x + g.conic_x + g.r + g.opacity));
  for (const auto& near : {0.01, 0.2, 1.0}) {
    o.near_z = near;
    const Compare r = compare(R.r, c, cam, o, 0.01);
    report("degenerate set", r);
  }
  // opacity 1 alone: α is 0.99 at the centre, never 1
  splat::GaussianCloud one;
  one.sh_degree = 1;
  one.add({0.0, 0.0, 0.0}, glm::vec3(0.3f), q0, 1.0f, coeffs.data());
  o.near_z = 0.01;
  o.pixels = render::PixelConvention::Integer;  // pixel (40, 30) is sampled at the projected centre
  const auto img = R.r.render(R.r.upload(one), cam, o);
  float amax = 0.0f;
  for (size_t p = 0; p < size_t{80} * 60; ++p) amax = std::max(amax, img.rgba[4 * p + 3]);
  CHECK(amax == doctest::Approx(0.99f));
}

// lavapipe silently ends every loop of a shader invocation after 65,535 iterations in all, so
// splat_blend counts its loop iterations against SplatBlendParams::loop_budget and the renderer
// throws instead of returning a blend cut short. Forced small budget: the clear error; the
// device's own budget: the same frame renders and matches the CPU reference.
TEST_CASE("splat gpu: a tile over the blend's loop budget is an error, not a cut-short image") {
  splat::GaussianCloud c;
  c.sh_degree = 0;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  const float dc[3] = {0.5f, 0.2f, -0.3f};
  for (int i = 0; i < 3000; ++i)  // faint, overlapping: no pixel saturates before the end
    c.add({u(rng), u(rng), u(rng)}, glm::vec3(0.04f), glm::vec4(1, 0, 0, 0), 0.004f, dc);
  const auto cam = test::look_at_camera({0.0, -3.0, 0.0}, {0.0, 0.0, 0.0}, 37, 29, 30.0);
  SplatOptions o;
  o.background = {0.1f, 0.2f, 0.3f};
  {
    splat::SplatGpuVariant v;
    v.blend_loop_budget = 500;
    splat::SplatRendererGpu r(test::gpu_context(), v);
    CHECK_THROWS_WITH_AS(r.render(r.upload(c), cam, o), doctest::Contains("blend loop iterations"), std::runtime_error);
  }
  splat::SplatRendererGpu r(test::gpu_context());
  const Compare cmp = compare(r, c, cam, o, 0.002);
  CHECK(cmp.instances > 3000);
  std::printf("loop budget scene: %zu visible, %zu instances, band %zu of %zu pixels, max interior %.3g\n", cmp.visible,
              cmp.instances, cmp.band, cmp.pixels, cmp.max_interior);
}

// splat/blend.comp skips, per batch, the column groups (SPLAT_BLEND_G = 8 columns × the subgroup's
// rows; the test covers every 4th column boundary, so groups of 4 too) that
// a Gaussian's α-cut ellipse cannot reach, and tests rows against the subgroup's block. Small
// Gaussians centred 1.5 px outside every group and block boundary reach exactly one column
// (row) across it: a group or block skipped wrongly loses that column (row), far more than
// the threshold-flip band. Odd image size (partial tiles), both pixel conventions, plus
// thin rotated Gaussians.
TEST_CASE("splat gpu: blend column-group and row-block skipping, Gaussians reaching one column or row of a block" * doctest::test_suite("subgroup-sensitive")) {
  Renderer R;
  const uint32_t W = 77, H = 45;  // 5 × 3 tiles, the last ones partial
  const double f = 100.0, z = 5.0;
  render::Camera cam;  // at the origin looking along +z (OpenCV axes)
  cam.K = {f, f, 0.5 * W, 0.5 * H, W, H};
  for (const auto conv : {render::PixelConvention::Centre, render::PixelConvention::Integer}) {
    CAPTURE(int(conv));
    const double o = render::pixel_offset(conv);
    splat::GaussianCloud c;
    c.sh_degree = 0;
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
    auto add = [&](double mx, double my, const glm::vec3& scale, const glm::vec4& q, float op) {
      const float dc[3] = {float(u(rng) / splat::kShC0), float(u(rng) / splat::kShC0), float(u(rng) / splat::kShC0)};
      const double zi = z + 0.5 * u01(rng);  // projects to (mx, my) at any depth
      c.add({(mx - cam.K.cx) * zi / f, (my - cam.K.cy) * zi / f, zi}, scale, q, op, dc);
    };
    // σ = 0.01 m → 0.18–0.2 px, with the 0.3 px² dilation σ ≈ 0.58 px: at opacity 0.9 a sample
    // 1.5 px away gets α ≈ 0.03, one 2.5 px away α < 1/255.
    const glm::vec3 tiny(0.01f);
    const glm::vec4 q0(1, 0, 0, 0);
    for (uint32_t bx = 4; bx < W; bx += 4)  // column group boundaries (every 4th column)
      for (uint32_t yy = 1; yy < H; yy += 6) {
        const double sy = yy + o + 0.3 * u(rng);
        add(bx + o - 1.5, sy, tiny, q0, 0.9f);        // reaches column bx only, of the group right of it
        add(bx - 1 + o + 1.5, sy + 3.0, tiny, q0, 0.9f);  // reaches column bx − 1 only, of the group left of it
      }
    for (uint32_t by = 8; by < H; by += 8)  // row block boundaries (subgroup blocks of 8 rows)
      for (uint32_t xx = 1; xx < W; xx += 5) {
        const double sx = xx + o + 0.3 * u(rng);
        add(sx, by + o - 1.5, tiny, q0, 0.9f);
        add(sx + 2.5, by - 1 + o + 1.5, tiny, q0, 0.9f);
      }
    // Thin needles rotated about 45° in the image plane at random places: their chords reach
    // a group or block at a few rows or columns only.
    for (int i = 0; i < 40; ++i) {
      const double a = 0.25 * 3.14159265358979 + 0.2 * u(rng);
      add(W * u01(rng), H * u01(rng), glm::vec3(0.1f, 0.004f, 0.004f),
          glm::vec4(float(std::cos(0.5 * a)), 0.0f, 0.0f, float(std::sin(0.5 * a))), 0.8f);
    }
    SplatOptions opts;
    opts.pixels = conv;
    opts.background = {0.1f, 0.2f, 0.3f};
    const Compare r = compare(R.r, c, cam, opts, 0.003);
    report(conv == render::PixelConvention::Centre ? "skip boundaries, centre samples" : "skip boundaries, integer samples",
           r);
  }
}

// SplatBinRecord packs tile coordinates in 16 bits: an image of more than 65,535 tile columns
// (here 1,048,576 × 1 px, within one storage binding) is refused with a clear message.
TEST_CASE("splat gpu: an image of more than 65,535 tile columns is an error") {
  Renderer R;
  splat::GaussianCloud c;
  c.sh_degree = 0;
  const float dc[3] = {1, 1, 1};
  c.add({0.0, 0.0, 5.0}, glm::vec3(0.1f), glm::vec4(1, 0, 0, 0), 0.9f, dc);
  render::Camera cam;
  cam.K = {100.0, 100.0, 524288.0, 0.5, 1048576, 1};
  CHECK_THROWS_WITH_AS(R.r.render(R.r.upload(c), cam, SplatOptions{}), doctest::Contains("65,535 tile columns"),
                       std::invalid_argument);
  cam.K = {100.0, 100.0, 500.0, 0.5, 1000, 1};  // a wide strip within the limit renders
  const auto img = R.r.render(R.r.upload(c), cam, SplatOptions{});
  CHECK(img.rgba.size() == 4000);
}

TEST_CASE("splat gpu: empty scene and Gaussians all culled give the background (both binning paths)") {
  for (const auto binning : {splat::TileBinning::Counting, splat::TileBinning::Radix}) {
    CAPTURE(static_cast<int>(binning));
    splat::SplatRendererGpu r(test::gpu_context(), splat::SplatGpuVariant{true, true, binning});
    splat::GaussianCloud c;
    c.sh_degree = 0;
    const auto cam = test::look_at_camera({0.0, -5.0, 0.0}, {0.0, 0.0, 0.0}, 40, 20, 30.0);
    SplatOptions o;
    o.background = {0.25f, 0.5f, 0.75f};
    for (int pass = 0; pass < 2; ++pass) {
      const auto img = r.render(r.upload(c), cam, o);
      for (size_t p = 0; p < 40 * 20; ++p) {
        CHECK(img.rgba[4 * p + 1] == 0.5f);
        CHECK(img.rgba[4 * p + 3] == 0.0f);
      }
      const float dc[3] = {1, 1, 1};
      c.add({0.0, -10.0, 0.0}, glm::vec3(0.1f), glm::vec4(1, 0, 0, 0), 0.9f, dc);  // behind the camera
    }
  }
}
