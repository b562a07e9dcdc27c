// Level of detail for static Gaussian sets (splat/gaussian_lod.h): the
// moment-matched merge against the formulas, chunking (a permutation, bounds
// holding every 3σ extent), the frustum test on boxes, and renders: the
// frustum- and distance-culled selection draws the same image as the whole
// set (GPU rasterizer), and a coarse level stays close to it.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "splat/gaussian_lod.h"
#include "splat/lod_gaussians_gpu.h"
#include "splat/splat_scene.h"
#include "splat/rasterizer_gpu.h"
#include "splat/test_splat_util.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <tuple>
#include <vector>

using namespace icube;

namespace {

glm::dmat3 covariance_of(const splat::GaussianCloud& c, size_t i) {
  const std::array<float, 6> v = splat::covariance3d(c.scales[i], c.rotations[i]);
  return glm::dmat3(v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5]);
}

double image_psnr(const splat::SplatImage& a, const splat::SplatImage& b, double* max_diff) {
  double se = 0.0;
  *max_diff = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) {
    if (i % 4 == 3) continue;
    const double d = double(a.rgba[i]) - double(b.rgba[i]);
    se += d * d;
    *max_diff = std::max(*max_diff, std::fabs(d));
    ++n;
  }
  return se > 0.0 ? -10.0 * std::log10(se / double(n)) : 99.0;
}

}  // namespace

TEST_CASE("gaussian lod: the moment-matched merge of Gaussians against its formulas") {
  const splat::GaussianCloud c = test::random_cloud(3, 7, 1, glm::dvec3(1.0, -2.0, 0.5), 0.3, -3.0, -1.0);
  std::vector<uint32_t> idx(c.size());
  for (uint32_t i = 0; i < idx.size(); ++i) idx[i] = i;
  splat::GaussianCloud m;
  m.sh_degree = c.sh_degree;
  splat::merge_gaussians(c, idx, m);
  REQUIRE(m.size() == 1);
  auto area = [](const glm::vec3& s) {
    std::array<double, 3> v = {s.x, s.y, s.z};
    std::sort(v.begin(), v.end());
    return v[1] * v[2];
  };
  double ws = 0.0, aa = 0.0;
  glm::dvec3 mu(0.0);
  for (size_t i = 0; i < c.size(); ++i) {
    const double w = double(c.opacities[i]) * area(c.scales[i]);
    ws += w, aa += w, mu += w * c.positions[i];
  }
  mu /= ws;
  glm::dmat3 cov(0.0);
  std::vector<double> sh(size_t(c.sh_coeffs()) * 3, 0.0);
  for (size_t i = 0; i < c.size(); ++i) {
    const double w = double(c.opacities[i]) * area(c.scales[i]);
    const glm::dvec3 d = c.positions[i] - mu;
    cov += w * (covariance_of(c, i) + glm::outerProduct(d, d));
    for (size_t k = 0; k < sh.size(); ++k) sh[k] += w * double(c.sh[i * sh.size() + k]);
  }
  cov /= ws;
  CHECK(glm::length(m.positions[0] - mu) < 1e-12);
  const glm::dmat3 got = covariance_of(m, 0);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) CHECK(std::fabs(got[a][b] - cov[a][b]) <= 1e-5 * (std::fabs(cov[0][0]) + std::fabs(cov[1][1]) + std::fabs(cov[2][2])));
  for (size_t k = 0; k < sh.size(); ++k) CHECK(double(m.sh[k]) == doctest::Approx(sh[k] / ws).epsilon(1e-6));
  CHECK(double(m.opacities[0]) == doctest::Approx(std::min(0.99, aa / area(m.scales[0]))).epsilon(1e-5));
  CHECK(std::fabs(glm::length(glm::dvec4(m.rotations[0])) - 1.0) < 1e-6);

  // One Gaussian is kept as it is.
  splat::GaussianCloud one;
  one.sh_degree = c.sh_degree;
  splat::merge_gaussians(c, {4}, one);
  CHECK(one.positions[0] == c.positions[4]);
  CHECK(one.scales[0] == c.scales[4]);
  CHECK(one.opacities[0] == c.opacities[4]);
}

TEST_CASE("gaussian lod: chunks are a permutation of the set, with bounds holding every 3-sigma extent") {
  const splat::GaussianCloud c = test::random_cloud(11, 5000, 0, glm::dvec3(-30.0, 40.0, 2.0), 60.0, -3.0, 0.0);
  splat::GaussianChunkOptions o;
  o.chunk_size = 12.8;
  const splat::ChunkedGaussians ch = splat::build_gaussian_chunks(c, o);
  REQUIRE(ch.fine.size() == c.size());
  CHECK(ch.coarse.size() < c.size());
  CHECK(ch.chunks.size() > 50);
  std::map<std::tuple<double, double, double>, int> seen;
  for (size_t i = 0; i < c.size(); ++i) ++seen[{c.positions[i].x, c.positions[i].y, c.positions[i].z}];
  size_t counted = 0, outside = 0;
  for (const splat::GaussianChunk& k : ch.chunks) {
    counted += k.count;
    for (uint32_t i = k.first; i < k.first + k.count; ++i) {
      const glm::dvec3 p = ch.fine.positions[i];
      --seen[{p.x, p.y, p.z}];
      const glm::vec3 s = ch.fine.scales[i];
      const double r = 3.0 * double(std::max({s.x, s.y, s.z}));
      if (glm::any(glm::lessThan(p - r, k.lo)) || glm::any(glm::greaterThan(p + r, k.hi))) ++outside;
    }
  }
  CHECK(counted == c.size());
  CHECK(outside == 0);
  for (const auto& [p, n] : seen) CHECK(n == 0);
  CHECK_THROWS_AS(splat::build_gaussian_chunks(c, {0.0, 0.8}), std::invalid_argument);
}

TEST_CASE("gaussian lod: boxes outside and inside a view") {
  const render::Camera cam = test::look_at_camera(glm::dvec3(0.0), glm::dvec3(10.0, 0.0, 0.0), 640, 360, 400.0);
  auto out = [&](glm::dvec3 lo, glm::dvec3 hi) { return splat::box_outside_view(lo, hi, cam, 0.01, 0.0); };
  CHECK_FALSE(out({9, -1, -1}, {11, 1, 1}));       // straight ahead
  CHECK(out({-11, -1, -1}, {-9, 1, 1}));           // behind
  CHECK(out({9, 20, -1}, {11, 22, 1}));            // far left of the 77-degree view
  CHECK(out({9, -22, -1}, {11, -20, 1}));          // far right
  CHECK(out({9, -1, 8}, {11, 1, 9}));              // above the 48-degree view
  CHECK_FALSE(out({-5, -5, -5}, {5, 5, 5}));       // holding the camera
  CHECK_FALSE(out({9, 7, -1}, {11, 9, 1}));        // straddling the left edge (x/z = 0.8 = 320/400)
  CHECK(out({9, 8.1, -1}, {10, 9, 1}));            // just beyond it
  CHECK_FALSE(splat::box_outside_view({9, 8.1, -1}, {10, 9, 1}, cam, 0.01, 30.0));  // within a 30-px margin
}

TEST_CASE("gaussian lod: the culled selection renders the whole set's image; the coarse level stays close") {
  // An 80 m square of Gaussians in a 1.6 m layer over the ground (~6 per 0.8 m merge cell), the camera
  // in it looking along +x.
  splat::GaussianCloud c = test::random_cloud(21, 60000, 0, glm::dvec3(0.0, 0.0, 1.0), 40.0, -2.5, -0.5);
  for (auto& p : c.positions) p.z = 0.02 * p.z;
  const render::Camera cam = test::look_at_camera(glm::dvec3(0.0, 3.0, 4.0), glm::dvec3(30.0, 0.0, 0.0), 320, 200, 220.0);
  splat::GaussianChunkOptions co;
  co.chunk_size = 10.0;
  const splat::ChunkedGaussians ch = splat::build_gaussian_chunks(c, co);
  splat::SplatRendererGpu r(test::gpu_context());
  splat::SplatOptions so;
  const splat::SplatImage full = r.render(r.upload(c), cam, so);

  splat::LodOptions lo;
  const splat::LodSelection culled = splat::select_gaussians(ch, cam, lo);
  CHECK(culled.chunks_out > 0);
  CHECK(culled.cloud.size() < c.size() * 6 / 10);
  double max_diff = 0.0;
  const double psnr_culled = image_psnr(r.render(r.upload(culled.cloud), cam, so), full, &max_diff);
  INFO("frustum culled: " << culled.cloud.size() << " of " << c.size() << " Gaussians, max diff " << max_diff);
  CHECK(max_diff < 1e-5);

  lo.coarse_distance = 15.0;
  const splat::LodSelection coarse = splat::select_gaussians(ch, cam, lo);
  CHECK(coarse.chunks_coarse > 0);
  CHECK(coarse.cloud.size() < culled.cloud.size() * 7 / 10);
  const double psnr_coarse = image_psnr(r.render(r.upload(coarse.cloud), cam, so), full, &max_diff);
  INFO("coarse beyond 15 m: " << coarse.cloud.size() << " Gaussians, PSNR " << psnr_coarse << " dB against the whole set");
  CHECK(psnr_coarse > 25.0);
  CHECK(psnr_culled > 80.0);  // 99 when identical

  lo.coarse_distance = 0.0;
  lo.max_distance = 25.0;
  const splat::LodSelection near = splat::select_gaussians(ch, cam, lo);
  CHECK(near.chunks_out > culled.chunks_out);
  for (size_t i = 0; i < near.cloud.size(); ++i) {
    const double d = glm::length(near.cloud.positions[i] - glm::dvec3(0.0, 3.0, 4.0));
    REQUIRE(d < 25.0 + 10.0 * 1.5 + 10.0);  // a kept chunk's bounds reach within 25 m
  }
}

namespace {

// The frame set's rows and SH as bytes-exact words (the float bits).
std::vector<uint32_t> words_of(const void* p, size_t bytes) {
  std::vector<uint32_t> w(bytes / 4);
  std::memcpy(w.data(), p, bytes);
  return w;
}

}  // namespace

TEST_CASE("gaussian lod: the GPU-assembled frame set equals the host selection plus the extra part, packed") {
  gpu::Context& ctx = test::gpu_context();
  splat::GaussianCloud c = test::random_cloud(31, 20000, 1, glm::dvec3(5.0, -3.0, 1.0), 40.0, -2.5, -0.5);
  splat::GaussianChunkOptions co;
  co.chunk_size = 10.0;
  const splat::ChunkedGaussians ch = splat::build_gaussian_chunks(c, co);
  splat::LodGaussiansGpu lod(ctx, ch, 2);  // a higher frame degree than the static set's: zero terms
  CHECK(lod.origin() == splat::gaussian_origin(ch.fine));
  const splat::GaussianCloud car_a = test::random_cloud(32, 300, 2, glm::dvec3(10.0, 0.0, 1.0), 2.0, -3.0, -1.5);
  const splat::GaussianCloud car_b = test::random_cloud(33, 170, 0, glm::dvec3(-8.0, 4.0, 1.0), 2.0, -3.0, -1.5);

  auto expect = [&](const render::Camera& cam, const splat::LodOptions& lo, const splat::GaussianCloud& extra,
                    const splat::GpuGaussians& g) {
    splat::GaussianCloud padded;  // the selection padded to the frame degree, as compose_frame does
    padded.sh_degree = 2;
    splat::append_cloud(padded, splat::select_gaussians(ch, cam, lo).cloud);
    splat::append_cloud(padded, extra);
    std::vector<shader::SplatGaussian> rows;
    std::vector<float> sh;
    splat::pack_gaussians(padded, lod.origin(), g.sh_stride, rows, sh);
    REQUIRE(g.count == padded.size());
    REQUIRE(g.sh_stride == splat::gpu_sh_stride(2));
    const auto got_rows = gpu::download_vector<shader::SplatGaussian>(ctx, g.gaussians, g.count);
    const auto got_sh = gpu::download_vector<float>(ctx, g.sh, size_t{g.count} * g.sh_stride);
    CHECK(test::equal_report(words_of(got_rows.data(), got_rows.size() * sizeof(rows[0])),
                             words_of(rows.data(), rows.size() * sizeof(rows[0])), "rows"));
    CHECK(test::equal_report(words_of(got_sh.data(), got_sh.size() * 4), words_of(sh.data(), sh.size() * 4), "sh"));
  };

  const render::Camera cam1 = test::look_at_camera(glm::dvec3(0.0, 3.0, 4.0), glm::dvec3(30.0, 0.0, 0.0), 320, 200, 220.0);
  const render::Camera cam2 = test::look_at_camera(glm::dvec3(20.0, -10.0, 6.0), glm::dvec3(-30.0, 5.0, 0.0), 320, 200, 220.0);
  splat::LodOptions lo;
  lo.coarse_distance = 12.0;
  splat::LodAssembleStats st;

  lod.set_extra(car_a);
  const splat::LodPicks p1 = splat::pick_chunks(lod.chunks(), cam1, lo);
  REQUIRE(p1.chunks_coarse > 0);
  REQUIRE(p1.chunks_fine > 0);
  expect(cam1, lo, car_a, lod.assemble(p1.picks, &st));
  CHECK(st.static_copied);
  CHECK(st.extra_uploaded);
  CHECK(st.copy_regions >= 1);

  // The same picks and a new extra part: only the extra part moves.
  lod.set_extra(car_b);
  expect(cam1, lo, car_b, lod.assemble(p1.picks, &st));
  CHECK_FALSE(st.static_copied);
  CHECK(st.extra_uploaded);
  // Nothing changed: nothing copied.
  lod.assemble(p1.picks, &st);
  CHECK_FALSE(st.static_copied);
  CHECK_FALSE(st.extra_uploaded);

  // Another view: the static part is copied again and the extra part follows it.
  const splat::LodPicks p2 = splat::pick_chunks(lod.chunks(), cam2, lo);
  REQUIRE(p2.picks != p1.picks);
  expect(cam2, lo, car_b, lod.assemble(p2.picks, &st));
  CHECK(st.static_copied);
  CHECK(st.extra_uploaded);

  // Every chunk fine (the frame set grows) and no extra part.
  lod.set_extra(splat::GaussianCloud{});
  splat::LodOptions all;
  all.frustum = false;
  const splat::LodPicks p3 = splat::pick_chunks(lod.chunks(), cam2, all);
  CHECK(p3.chunks_out == 0);
  const splat::GpuGaussians& g3 = lod.assemble(p3.picks, &st);
  CHECK(g3.count == c.size());
  expect(cam2, all, splat::GaussianCloud{}, g3);

  // Renders of the assembled set equal renders of the host path's upload.
  splat::SplatRendererGpu r(ctx);
  lod.set_extra(car_a);
  const splat::GpuGaussians& g1 = lod.assemble(p1.picks);
  splat::SplatScene host;
  host.static_set = splat::select_gaussians(ch, cam1, lo).cloud;
  splat::GaussianCloud host_cloud;
  host_cloud.sh_degree = 2;
  splat::append_cloud(host_cloud, host.static_set);
  splat::append_cloud(host_cloud, car_a);
  splat::GpuGaussians hg = r.upload(host_cloud);
  const splat::SplatImage a = r.render(g1, cam1, {}), b = r.render(hg, cam1, {});
  double max_diff = 0.0;
  image_psnr(a, b, &max_diff);
  INFO("origins " << g1.origin.x << "," << g1.origin.y << " vs " << hg.origin.x << "," << hg.origin.y);
  CHECK(max_diff < 1e-4);  // the same Gaussians; only the float positions' origin differs

  CHECK_THROWS_AS(lod.set_extra(test::random_cloud(34, 10, 3, glm::dvec3(0.0), 1.0)), std::invalid_argument);
}
