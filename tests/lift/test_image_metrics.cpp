// SSIM against a PyTorch float64 reference (Gaussian 11/1.5 window, valid
// convolution, C1 = 0.01², C2 = 0.03², as pytorch_msssim), with and without
// a mask; the exact distance transform against brute force on odd sizes;
// the percentile summary.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "lift/image_metrics.h"
#include "lift/package_eval.h"
#include "scene/atomic_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <tuple>
#include <vector>

using namespace icube;

namespace {

std::vector<uint8_t> noisy_image(uint32_t w, uint32_t h, uint32_t seed, const std::vector<uint8_t>* base = nullptr) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> n(-30, 30);
  std::vector<uint8_t> im(size_t(w) * h * 3);
  for (size_t i = 0; i < im.size(); ++i) {
    // Smooth structure (a gradient and stripes) plus noise, so SSIM is neither 0 nor 1.
    const size_t p = i / 3, x = p % w, y = p / w;
    const int v = base ? int((*base)[i]) + n(rng) : int((x * 7 + y * 3 + (i % 3) * 40 + ((x / 5) % 2) * 60) % 256);
    im[i] = uint8_t(std::clamp(v, 0, 255));
  }
  return im;
}

}  // namespace

TEST_CASE("image metrics: SSIM is 1 for identical images and matches a PyTorch reference, masked and not") {
  const uint32_t w = 37, h = 29;
  const std::vector<uint8_t> a = noisy_image(w, h, 1), b = noisy_image(w, h, 2, &a);
  CHECK(lift::ssim_rgb8(a, a, w, h) == doctest::Approx(1.0).epsilon(1e-12));
  std::vector<uint8_t> mask(size_t(w) * h, 0);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) mask[size_t(y) * w + x] = (x + 2 * y) % 3 != 0;
  const double s = lift::ssim_rgb8(a, b, w, h), sm = lift::ssim_rgb8(a, b, w, h, mask);
  CHECK(s > 0.2);
  CHECK(s < 0.99);
  const std::vector<uint8_t> small(10 * 10 * 3, 9);
  CHECK(lift::ssim_rgb8(small, small, 10, 10) == 0.0);  // smaller than the 11-pixel window: no window counts
  const std::string py = test::python_with("torch");
  if (py.empty()) {
    MESSAGE("skipped the PyTorch comparison: no python3 with torch (tools/install-deps.sh --test)");
    return;
  }
  test::TempDir dir("ssim");
  scene::write_file_atomic((dir.path / "a.bin").string(), std::string(a.begin(), a.end()));
  scene::write_file_atomic((dir.path / "b.bin").string(), std::string(b.begin(), b.end()));
  scene::write_file_atomic((dir.path / "m.bin").string(), std::string(mask.begin(), mask.end()));
  const std::string script = R"(
import torch, sys
w, h = 37, 29
d = sys.argv[1]
def img(n): return torch.frombuffer(bytearray(open(d + '/' + n, 'rb').read()), dtype=torch.uint8).double().view(h, w, 3).permute(2, 0, 1)[None] / 255
x, y = img('a.bin'), img('b.bin')
m = torch.frombuffer(bytearray(open(d + '/m.bin', 'rb').read()), dtype=torch.uint8).view(h, w)
g = torch.exp(-(torch.arange(11, dtype=torch.float64) - 5) ** 2 / (2 * 1.5 ** 2)); g = g / g.sum()
k = (g[:, None] * g[None, :]).expand(3, 1, 11, 11)
f = lambda t: torch.nn.functional.conv2d(t, k, groups=3)
mx, my = f(x), f(y)
sxx, syy, sxy = f(x * x) - mx ** 2, f(y * y) - my ** 2, f(x * y) - mx * my
c1, c2 = 0.01 ** 2, 0.03 ** 2
smap = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx ** 2 + my ** 2 + c1) * (sxx + syy + c2))
mm = m[5:h - 5, 5:w - 5].bool().expand(1, 3, h - 10, w - 10)
print('%.15f %.15f' % (smap.mean().item(), smap[mm].mean().item()))
)";
  scene::write_file_atomic((dir.path / "ssim.py").string(), script);
  const auto [code, out] = test::run_shell(py + " '" + (dir.path / "ssim.py").string() + "' '" + dir.path.string() + "'");
  INFO(out);
  REQUIRE(code == 0);
  double ref = 0.0, ref_masked = 0.0;
  REQUIRE(std::sscanf(out.c_str(), "%lf %lf", &ref, &ref_masked) == 2);
  CHECK(std::fabs(s - ref) < 1e-12);
  CHECK(std::fabs(sm - ref_masked) < 1e-12);
}

TEST_CASE("image metrics: SSIM rejects buffers of the wrong size") {
  const std::vector<uint8_t> a(30 * 20 * 3, 7);
  CHECK_THROWS_AS(lift::ssim_rgb8(a, a, 31, 20), std::invalid_argument);
  CHECK_THROWS_AS(lift::ssim_rgb8(a, a, 30, 20, std::vector<uint8_t>(5)), std::invalid_argument);
}

TEST_CASE("image metrics: the distance transform is exact against brute force") {
  for (const auto& [w, h, density, seed] : {std::tuple<uint32_t, uint32_t, int, uint32_t>{37, 23, 50, 1},
                                            {1, 17, 3, 2}, {19, 1, 4, 3}, {64, 48, 400, 4}, {33, 31, 1000, 5}}) {
    std::mt19937 rng(seed);
    std::vector<uint8_t> set(size_t(w) * h, 0);
    for (size_t i = 0; i < set.size(); ++i) set[i] = (rng() % uint32_t(density)) == 0;
    set[size_t(rng() % set.size())] = 1;
    const std::vector<float> d = lift::distance_transform(set, w, h);
    size_t bad = 0;
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x) {
        double best = std::numeric_limits<double>::infinity();
        for (uint32_t yy = 0; yy < h; ++yy)
          for (uint32_t xx = 0; xx < w; ++xx)
            if (set[size_t(yy) * w + xx]) best = std::min(best, std::hypot(double(x) - xx, double(y) - yy));
        const double got = double(d[size_t(y) * w + x]);
        if (std::fabs(got - best) > 1e-5 * (1.0 + best) && bad++ < 5)
          MESSAGE(w << "x" << h << " (" << x << "," << y << "): " << got << " vs " << best);
      }
    CHECK_MESSAGE(bad == 0, w << "x" << h);
  }
  const std::vector<float> none = lift::distance_transform(std::vector<uint8_t>(12, 0), 4, 3);
  for (float v : none) CHECK(std::isinf(v));
  CHECK_THROWS_AS(lift::distance_transform(std::vector<uint8_t>(11, 0), 4, 3), std::invalid_argument);
}

TEST_CASE("image metrics: PSNR of RGB8 images over a mask") {
  const std::vector<uint8_t> a(4 * 3 * 3, 100);
  std::vector<uint8_t> b = a;
  CHECK(lift::psnr_rgb8(a, b) == 99.0);
  for (size_t i = 0; i < 6 * 3; ++i) b[i] = 101;  // the first 6 pixels one level off
  CHECK(lift::psnr_rgb8(a, b) == doctest::Approx(20.0 * std::log10(255.0) + 10.0 * std::log10(2.0)));
  std::vector<uint8_t> mask(12, 0);
  for (size_t p = 0; p < 6; ++p) mask[p] = 1;
  CHECK(lift::psnr_rgb8(a, b, mask) == doctest::Approx(20.0 * std::log10(255.0)));
  for (size_t p = 0; p < 12; ++p) mask[p] = p >= 6;
  CHECK(lift::psnr_rgb8(a, b, mask) == 99.0);
  CHECK_THROWS_AS(lift::psnr_rgb8(a, b, std::vector<uint8_t>(5, 1)), std::invalid_argument);
}

TEST_CASE("image metrics: distance summaries (nearest-rank percentiles, share within tolerance)") {
  const lift::DistanceStats s = lift::distance_stats({5.0, 1.0, 0.0, 3.0, 2.0, 4.0, 6.0, 7.0, 8.0, 9.0}, 2.0);
  CHECK(s.samples == 10);
  CHECK(s.median == 4.0);
  CHECK(s.p90 == 8.0);
  CHECK(s.mean == doctest::Approx(4.5));
  CHECK(s.within == doctest::Approx(0.3));
  const lift::DistanceStats e = lift::distance_stats({}, 2.0);
  CHECK(e.samples == 0);
  CHECK(e.median == 0.0);
}
