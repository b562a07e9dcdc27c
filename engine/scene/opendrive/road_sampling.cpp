// Sampling of a road's lane borders (see road_sampling.h).
#include "scene/opendrive/road_sampling.h"

#include "scene/opendrive/lane_borders.h"

#include <algorithm>
#include <cmath>

namespace icube::scene::odr {

double SectionSamples::width(size_t i, size_t j) const { return std::fabs(t_at(i, j) - t_at(i, j + 1)); }

std::vector<SectionRange> section_ranges(const Road& road) {
  std::vector<SectionRange> out;
  const size_t n = road.sections.size();
  for (size_t k = 0; k < n; ++k) {
    const double a = std::max(0.0, road.sections[k].s);
    const double b = std::min(road.length, k + 1 < n ? road.sections[k + 1].s : road.length);
    if (b - a < 1e-9) continue;
    out.push_back({k, a, b});
  }
  return out;
}

std::vector<double> section_sample_s(const Road& road, const SectionRange& range, double step) {
  const double a = range.s_begin, b = range.s_end;
  const LaneSection& sec = road.sections[range.section];
  std::vector<double> s;
  const double count = std::floor((b - a) / step);
  s.reserve(static_cast<size_t>(count) + 8);
  for (double k = 0; k <= count; k += 1.0) s.push_back(a + k * step);
  auto add = [&](double v) {
    if (v > a && v < b) s.push_back(v);
  };
  for (const Geometry& g : road.geometries) add(g.s);
  for (const Cubic& c : road.lane_offset.records) add(c.s);
  auto add_lane = [&](const Lane& lane) {
    for (const Cubic& c : lane.widths) add(sec.s + c.s);
    if (lane.widths.empty())
      for (const Cubic& c : lane.borders) add(sec.s + c.s);
    for (const RoadMark& m : lane.marks) add(sec.s + m.s_offset);
  };
  for (const Lane& lane : sec.lanes) add_lane(lane);
  add_lane(sec.center);
  s.push_back(b);
  std::sort(s.begin(), s.end());
  std::vector<double> out;
  out.reserve(s.size());
  for (double v : s) {
    if (!out.empty() && v - out.back() < 1e-7) continue;
    out.push_back(v);
  }
  if (out.back() != b) {
    if (out.size() > 1 && b - out.back() < 1e-7) out.back() = b;
    else out.push_back(b);
  }
  return out;
}

double estimate_points(const Road& road, double step) {
  double total = 0.0;
  for (const SectionRange& r : section_ranges(road)) {
    const LaneSection& sec = road.sections[r.section];
    double breaks = 2.0 + static_cast<double>(road.geometries.size() + road.lane_offset.records.size());
    for (const Lane& l : sec.lanes) breaks += static_cast<double>(l.widths.size() + l.borders.size() + l.marks.size());
    const double samples = (r.s_end - r.s_begin) / step + breaks;
    total += samples * static_cast<double>(2 * sec.lanes.size() + 1);
  }
  return total;
}

std::vector<SectionSamples> sample_road(const Road& road, const ReferenceLine& line, double step) {
  std::vector<SectionSamples> out;
  const RoadFrame frame(road, line);
  std::vector<double> t;
  for (const SectionRange& r : section_ranges(road)) {
    const LaneSection& sec = road.sections[r.section];
    SectionSamples ss;
    ss.section = r.section;
    ss.s_begin = r.s_begin;
    ss.s_end = r.s_end;
    ss.borders = sec.border_count();
    ss.s = section_sample_s(road, r, step);
    ss.frames.reserve(ss.s.size());
    ss.t.reserve(ss.s.size() * ss.borders);
    ss.xyz.reserve(ss.s.size() * ss.borders);
    for (double s : ss.s) {
      const FramePoint f = frame.at(s);
      ss.frames.push_back(f);
      section_borders(sec, road.lane_offset, s, t);
      for (double tk : t) {
        ss.t.push_back(tk);
        ss.xyz.push_back(f.at(tk));
      }
    }
    out.push_back(std::move(ss));
  }
  return out;
}

}  // namespace icube::scene::odr
