// Per-road road edges: drivable/non-drivable borders, medians and curbs (see layers.h).
#include "scene/opendrive/layers.h"

#include "scene/opendrive/lane_borders.h"

namespace icube::scene::odr {

namespace {

constexpr double kVanishingWidth = 0.01;  // lanes narrower than this are transparent

enum class EdgeClass { None, Boundary, Median, Curb };

RoadEdgeType edge_type(EdgeClass c) {
  switch (c) {
    case EdgeClass::Boundary: return RoadEdgeType::Boundary;
    case EdgeClass::Median: return RoadEdgeType::Median;
    case EdgeClass::Curb: return RoadEdgeType::Curb;
    default: return RoadEdgeType::Unknown;
  }
}

class SectionEdges {
 public:
  SectionEdges(const LaneSection& sec, const SectionSamples& ss, const std::vector<std::string>& drivable_types)
      : sec_(sec), ss_(ss) {
    drivable_.reserve(sec.lanes.size());
    for (const Lane& l : sec.lanes) drivable_.push_back(is_drivable(drivable_types, l.type));
  }

  EdgeClass classify(size_t i, size_t k) const {
    const Lane& owner = k < sec_.n_left ? sec_.lanes[k] : k == sec_.n_left ? sec_.center : sec_.lanes[k - 1];
    if (const RoadMark* m = mark_at(owner, ss_.s[i] - sec_.s); m && m->type == "curb") return EdgeClass::Curb;
    const size_t n = sec_.lanes.size();
    // Border k is drawn by the outermost of several coincident borders: skip it when lane k-1 vanishes.
    if (k > 0 && vanishes(i, k - 1)) return EdgeClass::None;
    const long above = k > 0 ? static_cast<long>(k) - 1 : -1;
    long below = static_cast<long>(k);
    while (below < static_cast<long>(n) && vanishes(i, static_cast<size_t>(below))) ++below;
    if (below >= static_cast<long>(n)) below = -1;
    const bool da = above >= 0 && drivable_[static_cast<size_t>(above)];
    const bool db = below >= 0 && drivable_[static_cast<size_t>(below)];
    if (da == db) return EdgeClass::None;
    // Walk through the non-drivable side looking for a drivable lane beyond it.
    const long step = da ? 1 : -1;
    const long driving = da ? above : below;
    long j = da ? below : above;
    while (j >= 0 && j < static_cast<long>(n) && (!drivable_[static_cast<size_t>(j)] || vanishes(i, static_cast<size_t>(j))))
      j += step;
    if (j < 0 || j >= static_cast<long>(n) || j == driving) return EdgeClass::Boundary;
    const bool opposite = (sec_.lanes[static_cast<size_t>(j)].id > 0) != (sec_.lanes[static_cast<size_t>(driving)].id > 0);
    return opposite ? EdgeClass::Median : EdgeClass::Boundary;
  }

 private:
  bool vanishes(size_t i, size_t j) const { return ss_.width(i, j) < kVanishingWidth; }

  const LaneSection& sec_;
  const SectionSamples& ss_;
  std::vector<bool> drivable_;
};

}  // namespace

void emit_road_edges(const Road& road, const std::vector<SectionSamples>& samples,
                     const std::vector<std::string>& drivable_types, Map& map, int64_t& next_id) {
  const size_t first = map.road_edges.size();
  auto emit = [&](RoadEdge&& edge) {
    if (edge.points.size() < 2) return;
    for (size_t j = map.road_edges.size(); j-- > first;) {
      RoadEdge& prev = map.road_edges[j];
      if (prev.type == edge.type && join_polyline(prev.points, edge.points, 0.01)) return;
    }
    edge.id = kRoadEdgeIdBase + next_id++;
    map.road_edges.push_back(std::move(edge));
  };
  for (const SectionSamples& ss : samples) {
    const LaneSection& sec = road.sections[ss.section];
    const SectionEdges classes(sec, ss, drivable_types);
    const size_t n = ss.s.size();
    std::vector<EdgeClass> cls(n);
    for (size_t k = 0; k < ss.borders; ++k) {
      for (size_t i = 0; i < n; ++i) cls[i] = classes.classify(i, k);
      size_t i = 0;
      while (i < n) {
        if (cls[i] == EdgeClass::None) {
          ++i;
          continue;
        }
        size_t j = i;
        while (j + 1 < n && cls[j + 1] == cls[i]) ++j;
        // A run reaches the next sample too, where the next class (or a gap) begins.
        const size_t end = j + 1 < n ? j + 1 : j;
        RoadEdge edge;
        edge.type = edge_type(cls[i]);
        for (size_t q = i; q <= end; ++q) edge.points.push_back(ss.point(q, k));
        emit(std::move(edge));
        i = j + 1;
      }
    }
  }
}

}  // namespace icube::scene::odr
