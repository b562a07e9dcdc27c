// InfiniCube's polyline resampling rule; see polyline_resample.h.
#include "world/polyline_resample.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace icube::world {

void append_resampled(std::vector<glm::dvec3>& out, const std::vector<glm::dvec3>& points, double step) {
  if (!(step > 0.0) || !std::isfinite(step)) throw std::invalid_argument("resample_polyline: step must be > 0");
  if (points.empty()) return;
  for (size_t s = 0; s + 1 < points.size(); ++s) {
    const glm::dvec3 a = points[s], b = points[s + 1];
    const double d = glm::length(b - a);
    // ceil of a non-finite or huge length would overflow; such input is garbage.
    if (!std::isfinite(d) || d / step > 1e7) throw std::invalid_argument("resample_polyline: segment too long or not finite");
    const long n = std::max(static_cast<long>(std::ceil(d / step)), 2L);
    for (long k = 0; k < n - 1; ++k) {
      const double t = static_cast<double>(k) / static_cast<double>(n - 1);
      out.push_back(a + (b - a) * t);
    }
  }
  out.push_back(points.back());
}

std::vector<glm::dvec3> resample_polyline(const std::vector<glm::dvec3>& points, double step) {
  std::vector<glm::dvec3> out;
  append_resampled(out, points, step);
  return out;
}

}  // namespace icube::world
