// Lane border t values of a lane section (see lane_borders.h).
#include "scene/opendrive/lane_borders.h"

#include <algorithm>

namespace icube::scene::odr {

const Cubic* record_at(const std::vector<Cubic>& records, double ds) {
  if (records.empty()) return nullptr;
  auto it = std::upper_bound(records.begin(), records.end(), ds, [](double v, const Cubic& c) { return v < c.s; });
  return it == records.begin() ? &records.front() : &*(it - 1);
}

double lane_width(const Lane& lane, double ds) {
  const Cubic* c = record_at(lane.widths, ds);
  return c ? c->value(std::max(0.0, ds - c->s)) : 0.0;
}

const RoadMark* mark_at(const Lane& lane, double ds) {
  if (lane.marks.empty()) return nullptr;
  auto it = std::upper_bound(lane.marks.begin(), lane.marks.end(), ds,
                             [](double v, const RoadMark& m) { return v < m.s_offset; });
  return it == lane.marks.begin() ? nullptr : &*(it - 1);
}

void section_borders(const LaneSection& sec, const CubicProfile& lane_offset, double s, std::vector<double>& t) {
  const size_t n = sec.lanes.size();
  const size_t nl = sec.n_left;
  t.assign(n + 1, 0.0);
  const double ds = s - sec.s;
  t[nl] = lane_offset.value(s);
  auto outer = [&](const Lane& lane, double inner, double sign) {
    if (!lane.widths.empty() || lane.borders.empty()) return inner + sign * lane_width(lane, ds);
    const Cubic* b = record_at(lane.borders, ds);
    return b->value(std::max(0.0, ds - b->s));
  };
  for (size_t k = nl; k-- > 0;) t[k] = outer(sec.lanes[k], t[k + 1], 1.0);    // left: lane k between t[k] (outer) and t[k+1]
  for (size_t k = nl; k < n; ++k) t[k + 1] = outer(sec.lanes[k], t[k], -1.0);  // right: lane k between t[k] and t[k+1] (outer)
}

}  // namespace icube::scene::odr
