// Uniform-bin segment index (see segment_index.h).
#include "world/procedural/segment_index.h"

#include <algorithm>
#include <cmath>

namespace icube::world::procedural {

uint64_t SegmentIndex::key(int64_t bx, int64_t by) const {
  return (static_cast<uint64_t>(bx) << 32) ^ (static_cast<uint64_t>(by) & 0xFFFFFFFFull);
}

void SegmentIndex::add(const glm::dvec2& a, const glm::dvec2& b) {
  const double len = glm::length(b - a);
  if (!(len > 1e-9) || !std::isfinite(len)) return;
  const int pieces = std::max(1, static_cast<int>(std::ceil(len / bin_)));
  for (int k = 0; k < pieces; ++k) {
    const glm::dvec2 p0 = a + (b - a) * (double(k) / pieces), p1 = a + (b - a) * (double(k + 1) / pieces);
    const auto id = static_cast<uint32_t>(segs_.size());
    segs_.push_back({p0, p1});
    const glm::dvec2 lo = glm::min(p0, p1), hi = glm::max(p0, p1);
    for (auto bx = static_cast<int64_t>(std::floor(lo.x / bin_)); bx <= static_cast<int64_t>(std::floor(hi.x / bin_)); ++bx)
      for (auto by = static_cast<int64_t>(std::floor(lo.y / bin_)); by <= static_cast<int64_t>(std::floor(hi.y / bin_));
           ++by)
        bins_[key(bx, by)].push_back(id);
  }
}

void SegmentIndex::add_polyline(const std::vector<glm::dvec3>& points) {
  for (size_t i = 1; i < points.size(); ++i) add(glm::dvec2(points[i - 1]), glm::dvec2(points[i]));
}

SegmentIndex::Hit SegmentIndex::nearest(const glm::dvec2& p, double max_r) const {
  Hit best;
  uint32_t best_id = 0;
  if (segs_.empty()) return best;
  const auto bx0 = static_cast<int64_t>(std::floor((p.x - max_r) / bin_));
  const auto bx1 = static_cast<int64_t>(std::floor((p.x + max_r) / bin_));
  const auto by0 = static_cast<int64_t>(std::floor((p.y - max_r) / bin_));
  const auto by1 = static_cast<int64_t>(std::floor((p.y + max_r) / bin_));
  for (int64_t bx = bx0; bx <= bx1; ++bx)
    for (int64_t by = by0; by <= by1; ++by) {
      const auto it = bins_.find(key(bx, by));
      if (it == bins_.end()) continue;
      for (uint32_t id : it->second) {
        const Seg& s = segs_[id];
        const glm::dvec2 d = s.b - s.a;
        const double t = std::clamp(glm::dot(p - s.a, d) / glm::dot(d, d), 0.0, 1.0);
        const glm::dvec2 q = s.a + d * t;
        const double dist = glm::length(p - q);
        if (dist > max_r) continue;
        if (!best.found || dist < best.distance || (dist == best.distance && id < best_id)) {
          best.found = true, best.distance = dist, best.point = q, best.dir = glm::normalize(d), best_id = id;
        }
      }
    }
  return best;
}

}  // namespace icube::world::procedural
