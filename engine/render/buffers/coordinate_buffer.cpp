// Coordinate buffer points, sampling, quantiles and encoding; see coordinate_buffer.h.
#include "render/buffers/coordinate_buffer.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <unordered_set>

namespace icube::render {

std::vector<float> coordinate_points(const PinholeIntrinsics& K, const std::vector<float>& zdepth,
                                     const glm::dmat4& rel, PixelConvention pixels) {
  const size_t n = static_cast<size_t>(K.width) * K.height;
  if (zdepth.size() != n) throw std::invalid_argument("coordinate_points: depth size differs from the image");
  std::vector<float> out(n * 3, 0.0f);
  for (size_t i = 0; i < n; ++i) {
    const double z = zdepth[i];
    if (!(z > 0.0)) continue;
    const glm::dvec3 p = coordinate_point(K, i, z, rel, pixels);
    out[3 * i + 0] = static_cast<float>(p.x);
    out[3 * i + 1] = static_cast<float>(p.y);
    out[3 * i + 2] = static_cast<float>(p.z);
  }
  return out;
}

double quantile_linear(std::vector<double>& values, double q) {
  if (values.empty()) return 0.0;
  const double pos = q * static_cast<double>(values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(lo), values.end());
  const double a = values[lo];
  double b = a;
  if (hi != lo) b = *std::min_element(values.begin() + static_cast<std::ptrdiff_t>(lo) + 1, values.end());
  return a + (b - a) * (pos - static_cast<double>(lo));
}

CoordinateRange coordinate_range_of(const std::vector<glm::dvec3>& points) {
  CoordinateRange r;
  r.samples = points.size();
  for (int a = 0; a < 3; ++a) {
    std::vector<double> v(points.size());
    for (size_t i = 0; i < points.size(); ++i) v[i] = points[i][a];
    const double lo = quantile_linear(v, kCoordinateLowQuantile);
    const double hi = quantile_linear(v, kCoordinateHighQuantile);
    r.min[a] = lo;
    r.range[a] = std::max(hi - lo, kCoordinateMinRange);
  }
  return r;
}

glm::dvec3 coordinate_point(const PinholeIntrinsics& K, size_t i, double z, const glm::dmat4& rel, PixelConvention pixels) {
  const double o = pixel_offset(pixels);
  const double u = static_cast<double>(i % K.width), v = static_cast<double>(i / K.width);
  const glm::dvec3 pc(z * (u + o - K.cx) / K.fx, z * (v + o - K.cy) / K.fy, z);
  return glm::dmat3(rel) * pc + glm::dvec3(rel[3]);
}

CoordinateRange coordinate_range(const PinholeIntrinsics& K, const std::vector<const std::vector<float>*>& zdepth,
                                 const std::vector<glm::dmat4>& rel, PixelConvention pixels, uint64_t seed,
                                 size_t max_samples) {
  if (rel.size() != zdepth.size()) throw std::invalid_argument("coordinate_range: frame counts differ");
  std::vector<uint64_t> first(zdepth.size() + 1, 0);  // valid pixels before frame f
  for (size_t f = 0; f < zdepth.size(); ++f) {
    uint64_t c = 0;
    for (float z : *zdepth[f]) c += z > 0.0f;
    first[f + 1] = first[f] + c;
  }
  const uint64_t n = first.back();
  std::vector<uint64_t> chosen;
  if (n <= max_samples) {
    chosen.resize(n);
    for (uint64_t i = 0; i < n; ++i) chosen[i] = i;
  } else {
    // Floyd: k distinct indices out of n.
    std::mt19937_64 rng(seed);
    std::unordered_set<uint64_t> set;
    set.reserve(max_samples * 2);
    for (uint64_t j = n - max_samples; j < n; ++j) {
      const uint64_t t = rng() % (j + 1);
      if (!set.insert(t).second) set.insert(j);
    }
    chosen.assign(set.begin(), set.end());
    std::sort(chosen.begin(), chosen.end());
  }
  std::vector<glm::dvec3> pts;
  pts.reserve(chosen.size());
  size_t f = 0, pix = 0;
  uint64_t seen = 0;  // valid pixels passed in frame f before pix
  for (uint64_t g : chosen) {
    while (g >= first[f + 1]) {
      ++f;
      pix = 0;
      seen = 0;
    }
    const uint64_t local = g - first[f];
    const std::vector<float>& z = *zdepth[f];
    while (true) {
      if (z[pix] > 0.0f) {
        if (seen == local) break;
        ++seen;
      }
      ++pix;
    }
    pts.push_back(coordinate_point(K, pix, z[pix], rel[f], pixels));
  }
  return coordinate_range_of(pts);
}

std::vector<uint8_t> encode_coordinates(const std::vector<float>& points, const std::vector<float>& zdepth,
                                        const CoordinateRange& r) {
  if (points.size() != zdepth.size() * 3) throw std::invalid_argument("encode_coordinates: sizes differ");
  std::vector<uint8_t> out(points.size(), 255);
  for (size_t i = 0; i < zdepth.size(); ++i) {
    if (!(zdepth[i] > 0.0f)) continue;
    for (int a = 0; a < 3; ++a) {
      const double p = points[3 * i + static_cast<size_t>(a)];
      const double pn = std::clamp(2.0 * (p - r.min[a]) / r.range[a] - 1.0, -1.0, 1.0);
      out[3 * i + static_cast<size_t>(a)] = static_cast<uint8_t>((pn + 1.0) / 2.0 * 255.0);
    }
  }
  return out;
}

}  // namespace icube::render
