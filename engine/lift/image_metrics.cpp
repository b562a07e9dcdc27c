#include "lift/image_metrics.h"

#include "lift/heldout_render.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace icube::lift {

namespace {

constexpr int kWindow = 11;
constexpr double kSigma = 1.5;

std::vector<double> gaussian_window() {
  std::vector<double> w(kWindow);
  double s = 0.0;
  for (int i = 0; i < kWindow; ++i) {
    const double x = double(i - kWindow / 2);
    w[size_t(i)] = std::exp(-x * x / (2.0 * kSigma * kSigma));
    s += w[size_t(i)];
  }
  for (double& v : w) v /= s;
  return w;
}

// Valid separable filtering of a W×H plane: (W−10)×(H−10) outputs.
std::vector<double> filter_valid(const std::vector<double>& in, uint32_t W, uint32_t H, const std::vector<double>& w) {
  const uint32_t ow = W - kWindow + 1, oh = H - kWindow + 1;
  std::vector<double> rows(size_t(ow) * H), out(size_t(ow) * oh);
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < ow; ++x) {
      double s = 0.0;
      for (int k = 0; k < kWindow; ++k) s += w[size_t(k)] * in[size_t(y) * W + x + uint32_t(k)];
      rows[size_t(y) * ow + x] = s;
    }
  for (uint32_t y = 0; y < oh; ++y)
    for (uint32_t x = 0; x < ow; ++x) {
      double s = 0.0;
      for (int k = 0; k < kWindow; ++k) s += w[size_t(k)] * rows[size_t(y + uint32_t(k)) * ow + x];
      out[size_t(y) * ow + x] = s;
    }
  return out;
}

}  // namespace

double ssim_rgb8(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, uint32_t width, uint32_t height,
                 const std::vector<uint8_t>& mask) {
  const size_t px = size_t(width) * height;
  if (a.size() != px * 3 || b.size() != px * 3 || (!mask.empty() && mask.size() != px))
    throw std::invalid_argument("ssim_rgb8: image sizes differ from width x height");
  if (width < uint32_t(kWindow) || height < uint32_t(kWindow)) return 0.0;
  const std::vector<double> w = gaussian_window();
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  const uint32_t ow = width - kWindow + 1, oh = height - kWindow + 1;
  double sum = 0.0;
  size_t counted = 0;
  std::vector<double> x(px), y(px), xx(px), yy(px), xy(px);
  for (int c = 0; c < 3; ++c) {
    for (size_t p = 0; p < px; ++p) {
      x[p] = double(a[3 * p + size_t(c)]) / 255.0;
      y[p] = double(b[3 * p + size_t(c)]) / 255.0;
      xx[p] = x[p] * x[p];
      yy[p] = y[p] * y[p];
      xy[p] = x[p] * y[p];
    }
    const std::vector<double> mx = filter_valid(x, width, height, w), my = filter_valid(y, width, height, w),
                              sxx = filter_valid(xx, width, height, w), syy = filter_valid(yy, width, height, w),
                              sxy = filter_valid(xy, width, height, w);
    for (uint32_t j = 0; j < oh; ++j)
      for (uint32_t i = 0; i < ow; ++i) {
        if (!mask.empty() && !mask[size_t(j + kWindow / 2) * width + i + kWindow / 2]) continue;
        const size_t q = size_t(j) * ow + i;
        const double vx = sxx[q] - mx[q] * mx[q], vy = syy[q] - my[q] * my[q], cxy = sxy[q] - mx[q] * my[q];
        sum += ((2.0 * mx[q] * my[q] + c1) * (2.0 * cxy + c2)) /
               ((mx[q] * mx[q] + my[q] * my[q] + c1) * (vx + vy + c2));
        ++counted;
      }
  }
  return counted ? sum / double(counted) : 0.0;
}

double psnr_rgb8(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, const std::vector<uint8_t>& mask) {
  if (a.size() != b.size() || a.size() % 3 != 0 || (!mask.empty() && mask.size() * 3 != a.size()))
    throw std::invalid_argument("psnr_rgb8: image and mask sizes differ");
  double se = 0.0;
  size_t n = 0;
  for (size_t p = 0; p < a.size() / 3; ++p) {
    if (!mask.empty() && !mask[p]) continue;
    for (size_t c = 0; c < 3; ++c) {
      const double d = (double(a[3 * p + c]) - double(b[3 * p + c])) / 255.0;
      se += d * d;
    }
    ++n;
  }
  return psnr_from_mse(n ? se / (3.0 * double(n)) : 0.0);
}

namespace {

// Squared distance transform of one line f (0 at set samples, +inf elsewhere) in place.
void edt_1d(std::vector<double>& f, size_t n, std::vector<double>& d, std::vector<int>& v, std::vector<double>& z) {
  const double inf = std::numeric_limits<double>::infinity();
  int k = -1;
  for (size_t q = 0; q < n; ++q) {
    if (std::isinf(f[q])) continue;
    const double fq = f[q] + double(q) * double(q);
    while (k >= 0) {
      const int p = v[size_t(k)];
      const double s = (fq - (f[size_t(p)] + double(p) * double(p))) / (2.0 * (double(q) - double(p)));
      if (s <= z[size_t(k)]) {
        --k;
        continue;
      }
      z[size_t(k) + 1] = s;
      break;
    }
    ++k;
    v[size_t(k)] = int(q);
    if (k == 0) z[0] = -inf;
    z[size_t(k) + 1] = inf;
  }
  if (k < 0) {
    for (size_t q = 0; q < n; ++q) d[q] = inf;
  } else {
    int j = 0;
    for (size_t q = 0; q < n; ++q) {
      while (z[size_t(j) + 1] < double(q)) ++j;
      const double dq = double(q) - double(v[size_t(j)]);
      d[q] = dq * dq + f[size_t(v[size_t(j)])];
    }
  }
  for (size_t q = 0; q < n; ++q) f[q] = d[q];
}

}  // namespace

std::vector<float> distance_transform(const std::vector<uint8_t>& set, uint32_t width, uint32_t height) {
  const size_t px = size_t(width) * height;
  if (set.size() != px) throw std::invalid_argument("distance_transform: mask size differs from width x height");
  const double inf = std::numeric_limits<double>::infinity();
  const size_t n = std::max(width, height);
  std::vector<double> g(px), line(n), d(n), z(n + 1);
  std::vector<int> v(n);
  for (size_t p = 0; p < px; ++p) g[p] = set[p] ? 0.0 : inf;
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x) line[x] = g[size_t(y) * width + x];
    edt_1d(line, width, d, v, z);
    for (uint32_t x = 0; x < width; ++x) g[size_t(y) * width + x] = line[x];
  }
  for (uint32_t x = 0; x < width; ++x) {
    for (uint32_t y = 0; y < height; ++y) line[y] = g[size_t(y) * width + x];
    edt_1d(line, height, d, v, z);
    for (uint32_t y = 0; y < height; ++y) g[size_t(y) * width + x] = line[y];
  }
  std::vector<float> out(px);
  for (size_t p = 0; p < px; ++p) out[p] = std::isinf(g[p]) ? std::numeric_limits<float>::infinity() : float(std::sqrt(g[p]));
  return out;
}

}  // namespace icube::lift
