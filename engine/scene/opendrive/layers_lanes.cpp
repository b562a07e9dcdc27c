// Lane centre lines in driving direction, their neighbours and the lane
// graph (see layers.h).
#include "scene/opendrive/layers.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace icube::scene::odr {

namespace {

// The road <type> record in force at s (the first one before its start); nullptr when none.
const RoadType* road_type_at(const Road& road, double s) {
  const RoadType* in_force = nullptr;
  for (const RoadType& t : road.types)
    if (t.s <= s + 1e-9 || !in_force) in_force = &t;
  return in_force;
}

double speed_mph(const Road& road, const Lane& lane, double s) {
  double mps = lane.speed_mps;
  if (mps < 0.0)
    if (const RoadType* t = road_type_at(road, s)) mps = t->speed_mps;
  return mps > 0.0 ? mps / 0.44704 : 0.0;
}

void add_unique(std::vector<int64_t>& v, int64_t id) {
  if (std::find(v.begin(), v.end(), id) == v.end()) v.push_back(id);
}

}  // namespace

void emit_lanes(const Road& road, size_t road_ordinal, const std::vector<SectionSamples>& samples, Map& map,
                std::vector<LaneSpan>& spans) {
  const size_t first = map.lanes.size();
  spans.resize(first);
  std::vector<size_t> prev_map;    // lane index in the previous section -> map index (or npos)
  constexpr size_t npos = static_cast<size_t>(-1);
  struct Adjacent {
    size_t left, right;  // map indices, left/right as seen in driving direction
  };
  std::vector<Adjacent> adjacent;
  for (const SectionSamples& ss : samples) {
    const LaneSection& sec = road.sections[ss.section];
    const RoadType* road_type = road_type_at(road, ss.s_begin);
    const bool motorway = road_type && road_type->type == "motorway";
    std::vector<size_t> cur_map(sec.lanes.size(), npos);
    for (size_t j = 0; j < sec.lanes.size(); ++j) {
      const Lane& lane = sec.lanes[j];
      const std::optional<LaneType> type = lane_centre_type(lane.type, motorway);
      if (!type) continue;
      scene::Lane out;
      out.type = *type;
      out.speed_limit_mph = speed_mph(road, lane, ss.s_begin);
      out.points.reserve(ss.s.size());
      for (size_t i = 0; i < ss.s.size(); ++i)
        out.points.push_back(ss.frames[i].at(0.5 * (ss.t_at(i, j) + ss.t_at(i, j + 1))));
      const bool back = (lane.id > 0) != road.lht;
      // Continue a lane of the previous section that ends where this one starts.
      size_t target = npos;
      int best_rank = 3;
      for (size_t q = first; q < map.lanes.size(); ++q) {
        if (spans[q].backwards != back || map.lanes[q].type != out.type) continue;
        if (std::find(prev_map.begin(), prev_map.end(), q) == prev_map.end()) continue;
        if (glm::length(map.lanes[q].points.back() - out.points.front()) > 0.05) continue;
        const int sid = spans[q].last_lane;
        const int rank = lane.has_predecessor && lane.predecessor == sid ? 0 : sid == lane.id ? 1 : 2;
        if (rank < best_rank) best_rank = rank, target = q;
      }
      if (target != npos && join_polyline(map.lanes[target].points, out.points, 0.05)) {
        spans[target].last_section = ss.section;
        spans[target].last_lane = lane.id;
        cur_map[j] = target;
        continue;
      }
      out.id = lane_feature_id(road_ordinal, ss.section, lane.id);
      cur_map[j] = map.lanes.size();
      map.lanes.push_back(std::move(out));
      spans.push_back({road_ordinal, ss.section, lane.id, ss.section, lane.id, back});
    }
    // Neighbours: adjacent centre lanes with the same driving direction.
    for (size_t j = 0; j + 1 < sec.lanes.size(); ++j) {
      const size_t a = cur_map[j], b = cur_map[j + 1];  // a lies on the +t side of b
      if (a == npos || b == npos || spans[a].backwards != spans[b].backwards) continue;
      adjacent.push_back(spans[a].backwards ? Adjacent{b, a} : Adjacent{a, b});
    }
    prev_map = std::move(cur_map);
  }
  for (const Adjacent& adj : adjacent) {
    add_unique(map.lanes[adj.right].left_neighbors, map.lanes[adj.left].id);
    add_unique(map.lanes[adj.left].right_neighbors, map.lanes[adj.right].id);
  }
  for (size_t q = first; q < map.lanes.size(); ++q)
    if (spans[q].backwards) std::reverse(map.lanes[q].points.begin(), map.lanes[q].points.end());
}

glm::dvec2 lane_end_direction(const std::vector<glm::dvec3>& pts, bool at_end) {
  glm::dvec2 d(0.0);
  const size_t n = pts.size();
  for (size_t i = 1; i < n && glm::length(d) < 1e-6; ++i)
    d = at_end ? glm::dvec2(pts[n - i] - pts[n - i - 1]) : glm::dvec2(pts[i] - pts[i - 1]);
  const double len = glm::length(d);
  return len > 0.0 ? d / len : d;
}

void link_lanes(Map& map) {
  constexpr double kJoin = 0.10;
  constexpr double kCell = 1.0;
  const double cos_limit = std::cos(60.0 * 3.14159265358979323846 / 180.0);
  auto key = [&](const glm::dvec3& p, long dx, long dy) {
    const long gx = static_cast<long>(std::floor(p.x / kCell)) + dx;
    const long gy = static_cast<long>(std::floor(p.y / kCell)) + dy;
    return (static_cast<uint64_t>(static_cast<uint32_t>(gx)) << 32) | static_cast<uint32_t>(gy);
  };
  std::unordered_map<uint64_t, std::vector<size_t>> starts;
  for (size_t i = 0; i < map.lanes.size(); ++i)
    if (map.lanes[i].points.size() >= 2) starts[key(map.lanes[i].points.front(), 0, 0)].push_back(i);
  for (size_t a = 0; a < map.lanes.size(); ++a) {
    const std::vector<glm::dvec3>& pa = map.lanes[a].points;
    if (pa.size() < 2 || !map.lanes[a].exit_lanes.empty()) continue;  // linked by the map's topology
    const glm::dvec2 da = lane_end_direction(pa, true);
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy) {
        auto it = starts.find(key(pa.back(), dx, dy));
        if (it == starts.end()) continue;
        for (size_t b : it->second) {
          if (b == a) continue;
          const std::vector<glm::dvec3>& pb = map.lanes[b].points;
          if (glm::length(pb.front() - pa.back()) > kJoin) continue;
          if (glm::dot(da, lane_end_direction(pb, false)) < cos_limit) continue;
          add_unique(map.lanes[a].exit_lanes, map.lanes[b].id);
          add_unique(map.lanes[b].entry_lanes, map.lanes[a].id);
        }
      }
  }
}

}  // namespace icube::scene::odr
