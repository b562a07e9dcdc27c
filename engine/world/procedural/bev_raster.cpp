// Exact squared Euclidean distance transform on the procedural prior's BEV
// raster: two passes of the 1D lower-envelope-of-parabolas algorithm
// (Felzenszwalb & Huttenlocher 2012), columns then rows.
#include "world/procedural/bev_raster.h"

#include <algorithm>
#include <cmath>

namespace icube::world::procedural {

namespace {

// f: n samples (>= kFarSquared = no site); d: output. v, z: scratch of n and n + 1.
void edt_1d(const float* f, float* d, int n, size_t stride_f, size_t stride_d, std::vector<int>& v,
            std::vector<double>& z) {
  int k = -1;
  for (int q = 0; q < n; ++q) {
    const double fq = f[static_cast<size_t>(q) * stride_f];
    if (fq >= double(kFarSquared)) continue;  // not a site
    if (k < 0) {
      k = 0, v[0] = q, z[0] = -1e300, z[1] = 1e300;
      continue;
    }
    double s = 0.0;
    while (true) {  // terminates at k = 0 because z[0] = -inf
      const int p = v[static_cast<size_t>(k)];
      const double fp = f[static_cast<size_t>(p) * stride_f];
      s = ((fq + double(q) * q) - (fp + double(p) * p)) / (2.0 * (q - p));
      if (s > z[static_cast<size_t>(k)]) break;
      --k;
    }
    ++k;
    v[static_cast<size_t>(k)] = q, z[static_cast<size_t>(k)] = s, z[static_cast<size_t>(k) + 1] = 1e300;
  }
  if (k < 0) {
    for (int q = 0; q < n; ++q) d[static_cast<size_t>(q) * stride_d] = kFarSquared;
    return;
  }
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[static_cast<size_t>(j) + 1] < q) ++j;
    const int p = v[static_cast<size_t>(j)];
    const double dq = double(q - p);
    d[static_cast<size_t>(q) * stride_d] = static_cast<float>(dq * dq + double(f[static_cast<size_t>(p) * stride_f]));
  }
}

}  // namespace

std::vector<float> squared_distance_transform(const std::vector<uint8_t>& mask, int nx, int ny) {
  const size_t n = static_cast<size_t>(nx) * static_cast<size_t>(ny);
  std::vector<float> f(n), tmp(n), out(n);
  for (size_t i = 0; i < n; ++i) f[i] = mask[i] ? 0.0f : kFarSquared;
  const int m = std::max(nx, ny);
  std::vector<int> v(static_cast<size_t>(m) + 1);
  std::vector<double> z(static_cast<size_t>(m) + 2);
  for (int x = 0; x < nx; ++x)  // along y, per column x
    edt_1d(f.data() + x, tmp.data() + x, ny, static_cast<size_t>(nx), static_cast<size_t>(nx), v, z);
  for (int y = 0; y < ny; ++y) {  // along x, per row y
    const size_t row = static_cast<size_t>(y) * static_cast<size_t>(nx);
    edt_1d(tmp.data() + row, out.data() + row, nx, 1, 1, v, z);
  }
  return out;
}

}  // namespace icube::world::procedural
