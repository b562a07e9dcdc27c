// A uniform-bin spatial index of 2D segments for the procedural prior: the
// nearest segment to a point within a radius (distance, closest point,
// direction). Used for "which way does the nearest road run" (building
// orientation) and "how far is the ego path" (clearance when the map has no
// road surface). Deterministic: ties go to the lowest segment index.
#pragma once

#include <glm/glm.hpp>

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace icube::world::procedural {

class SegmentIndex {
 public:
  explicit SegmentIndex(double bin_size = 8.0) : bin_(bin_size) {}

  // Adds a -> b (x, y); zero-length segments are ignored. Long segments are
  // split into pieces no longer than a bin.
  void add(const glm::dvec2& a, const glm::dvec2& b);
  void add_polyline(const std::vector<glm::dvec3>& points);
  bool empty() const { return segs_.empty(); }

  struct Hit {
    bool found = false;
    double distance = 0.0;
    glm::dvec2 point{0.0};  // closest point on the segment
    glm::dvec2 dir{1.0, 0.0};  // unit direction of the segment
  };
  // Nearest segment whose distance is <= max_r.
  Hit nearest(const glm::dvec2& p, double max_r) const;

 private:
  struct Seg {
    glm::dvec2 a, b;
  };
  uint64_t key(int64_t bx, int64_t by) const;
  double bin_;
  std::vector<Seg> segs_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> bins_;
};

}  // namespace icube::world::procedural
