// A static 2-D k-d tree over points (median splits on the wider axis, small
// leaves) answering "squared distance to the nearest point, if below a limit".
// Used by the road-surface split rule (road_surface.cpp).
#pragma once

#include <glm/glm.hpp>

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

namespace icube::world {

class NearestPoints2d {
 public:
  explicit NearestPoints2d(std::vector<glm::dvec2> pts) : points_(std::move(pts)) {
    for (const glm::dvec2& p : points_) lo_ = glm::min(lo_, p), hi_ = glm::max(hi_, p);
    if (!points_.empty()) build(0, points_.size(), 0);
  }
  bool empty() const { return points_.empty(); }

  // Lowers `best` (a squared distance) to that of the nearest point when it is nearer.
  void nearest2(const glm::dvec2& q, double& best) const {
    if (points_.empty()) return;
    const glm::dvec2 d = glm::max(glm::max(lo_ - q, q - hi_), glm::dvec2(0.0));
    if (d.x * d.x + d.y * d.y < best) search(q, 0, points_.size(), 0, best);
  }

 private:
  static constexpr size_t kLeaf = 8;
  struct Node {
    double split = 0.0;
    int axis = 0;
  };

  void build(size_t lo, size_t hi, size_t node) {
    if (hi - lo <= kLeaf) return;
    if (nodes_.size() <= node) nodes_.resize(node + 1);
    glm::dvec2 mn(std::numeric_limits<double>::infinity()), mx(-std::numeric_limits<double>::infinity());
    for (size_t i = lo; i < hi; ++i) mn = glm::min(mn, points_[i]), mx = glm::max(mx, points_[i]);
    const int axis = mx.x - mn.x >= mx.y - mn.y ? 0 : 1;
    const size_t mid = lo + (hi - lo) / 2;
    std::nth_element(points_.begin() + static_cast<std::ptrdiff_t>(lo), points_.begin() + static_cast<std::ptrdiff_t>(mid),
                     points_.begin() + static_cast<std::ptrdiff_t>(hi),
                     [axis](const glm::dvec2& a, const glm::dvec2& b) { return a[axis] < b[axis]; });
    nodes_[node] = {points_[mid][axis], axis};
    build(lo, mid, 2 * node + 1);
    build(mid, hi, 2 * node + 2);
  }

  // Points [lo, mid) are <= split on the node's axis, [mid, hi) are >= split.
  void search(const glm::dvec2& q, size_t lo, size_t hi, size_t node, double& best) const {
    if (hi - lo <= kLeaf) {
      for (size_t i = lo; i < hi; ++i) {
        const glm::dvec2 d = points_[i] - q;
        best = std::min(best, d.x * d.x + d.y * d.y);
      }
      return;
    }
    const Node& n = nodes_[node];
    const size_t mid = lo + (hi - lo) / 2;
    const double diff = q[n.axis] - n.split;
    if (diff < 0.0) {
      search(q, lo, mid, 2 * node + 1, best);
      if (diff * diff < best) search(q, mid, hi, 2 * node + 2, best);
    } else {
      search(q, mid, hi, 2 * node + 2, best);
      if (diff * diff < best) search(q, lo, mid, 2 * node + 1, best);
    }
  }

  std::vector<glm::dvec2> points_;
  std::vector<Node> nodes_;
  glm::dvec2 lo_{std::numeric_limits<double>::infinity()}, hi_{-std::numeric_limits<double>::infinity()};
};


}  // namespace icube::world
