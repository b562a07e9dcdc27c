// Road lines from OpenDRIVE road marks, and helpers shared by the layer
// builders (see layers.h).
#include "scene/opendrive/layers.h"

#include "scene/opendrive/lane_borders.h"

#include <algorithm>

namespace icube::scene::odr {

int64_t lane_feature_id(size_t road_ordinal, size_t section, int lane_id) {
  return static_cast<int64_t>(road_ordinal + 1) * 100'000'000 + static_cast<int64_t>(section) * 1000 + (lane_id + 500);
}

std::optional<RoadLineType> road_line_type(const std::string& type, const std::string& color) {
  if (type == "none" || type == "grass" || type == "curb" || type.empty()) return std::nullopt;
  const bool yellow = color == "yellow";
  if (type == "solid") return yellow ? RoadLineType::SolidSingleYellow : RoadLineType::SolidSingleWhite;
  if (type == "broken") return yellow ? RoadLineType::BrokenSingleYellow : RoadLineType::BrokenSingleWhite;
  if (type == "solid solid") return yellow ? RoadLineType::SolidDoubleYellow : RoadLineType::SolidDoubleWhite;
  // Waymo has no broken double white; keep it as a broken white line.
  if (type == "broken broken") return yellow ? RoadLineType::BrokenDoubleYellow : RoadLineType::BrokenSingleWhite;
  if (type == "solid broken" || type == "broken solid")
    return yellow ? RoadLineType::PassingDoubleYellow : RoadLineType::SolidDoubleWhite;
  return RoadLineType::Unknown;  // botts dots, custom, edge, ...
}

std::optional<LaneType> lane_centre_type(const std::string& t, bool motorway) {
  if (t == "driving" || t == "entry" || t == "exit" || t == "onRamp" || t == "offRamp" || t == "connectingRamp" ||
      t == "slipLane")
    return motorway ? LaneType::Freeway : LaneType::SurfaceStreet;
  if (t == "biking") return LaneType::BikeLane;
  return std::nullopt;
}

bool is_drivable(const std::vector<std::string>& drivable_types, const std::string& lane_type) {
  return std::find(drivable_types.begin(), drivable_types.end(), lane_type) != drivable_types.end();
}

bool join_polyline(std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b, double tol) {
  if (a.empty() || b.empty() || glm::length(a.back() - b.front()) > tol) return false;
  a.insert(a.end(), b.begin() + 1, b.end());
  return true;
}

void emit_road_lines(const Road& road, const std::vector<SectionSamples>& samples, Map& map, int64_t& next_id) {
  const size_t first = map.road_lines.size();
  for (const SectionSamples& ss : samples) {
    const LaneSection& sec = road.sections[ss.section];
    for (size_t k = 0; k < ss.borders; ++k) {
      const Lane& owner = k < sec.n_left ? sec.lanes[k] : k == sec.n_left ? sec.center : sec.lanes[k - 1];
      for (size_t m = 0; m < owner.marks.size(); ++m) {
        const RoadMark& mark = owner.marks[m];
        const std::optional<RoadLineType> type = road_line_type(mark.type, mark.color);
        if (!type) continue;
        const double lo = std::max(ss.s_begin, sec.s + mark.s_offset);
        const double hi = std::min(ss.s_end, m + 1 < owner.marks.size() ? sec.s + owner.marks[m + 1].s_offset : ss.s_end);
        if (hi - lo < 1e-9) continue;
        RoadLine line;
        line.type = *type;
        line.source_type = mark.type + " " + mark.color;
        for (size_t i = 0; i < ss.s.size(); ++i)
          if (ss.s[i] >= lo - 1e-6 && ss.s[i] <= hi + 1e-6) line.points.push_back(ss.point(i, k));
        if (line.points.size() < 2) continue;
        bool joined = false;
        for (size_t j = map.road_lines.size(); j-- > first && !joined;) {
          RoadLine& prev = map.road_lines[j];
          if (prev.type == line.type && prev.source_type == line.source_type)
            joined = join_polyline(prev.points, line.points, 0.01);
        }
        if (joined) continue;
        line.id = kRoadLineIdBase + next_id++;
        map.road_lines.push_back(std::move(line));
      }
    }
  }
}

}  // namespace icube::scene::odr
