// Lane links from OpenDRIVE road, lane and junction links (see lane_topology.h).
#include "scene/opendrive/lane_topology.h"

#include "scene/opendrive/road_sampling.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <utility>

namespace icube::scene::odr {

namespace {

// One end of a lane within one lane section: where a link attaches.
struct LaneEnd {
  size_t road = 0, section = 0;
  int lane = 0;
  bool at_section_end = false;
  auto tie() const { return std::tie(road, section, lane, at_section_end); }
  bool operator<(const LaneEnd& o) const { return tie() < o.tie(); }
};

// Two lane ends that the document says touch (in no particular driving order).
using Contact = std::pair<LaneEnd, LaneEnd>;

// Sampled lane sections of every road, in +s order (skipped sections carry no lanes).
std::vector<std::vector<size_t>> sampled_sections(const Document& doc) {
  std::vector<std::vector<size_t>> out(doc.roads.size());
  for (size_t r = 0; r < doc.roads.size(); ++r)
    for (const SectionRange& range : section_ranges(doc.roads[r])) out[r].push_back(range.section);
  return out;
}

// The lane end of a road's contact point: first section's start or last section's end.
std::optional<LaneEnd> contact_end(size_t road, const std::vector<size_t>& sections, const std::string& contact_point,
                                   int lane) {
  if (sections.empty()) return std::nullopt;
  if (contact_point == "start") return LaneEnd{road, sections.front(), lane, false};
  if (contact_point == "end") return LaneEnd{road, sections.back(), lane, true};
  return std::nullopt;
}

// Lane <link>s between consecutive sampled sections of one road.
void section_contacts(const Road& road, size_t r, const std::vector<size_t>& sections, std::set<Contact>& out) {
  for (size_t k = 0; k + 1 < sections.size(); ++k) {
    const size_t a = sections[k], b = sections[k + 1];
    for (const Lane& l : road.sections[b].lanes)
      if (l.has_predecessor) out.insert({LaneEnd{r, a, l.predecessor, true}, LaneEnd{r, b, l.id, false}});
    for (const Lane& l : road.sections[a].lanes)
      if (l.has_successor) out.insert({LaneEnd{r, a, l.id, true}, LaneEnd{r, b, l.successor, false}});
  }
}

// Lane <link>s across the road's predecessor / successor link to another road.
void road_link_contacts(const Document& doc, size_t r, const std::map<std::string, size_t>& road_of,
                        const std::vector<std::vector<size_t>>& sections, std::set<Contact>& out) {
  const Road& road = doc.roads[r];
  if (sections[r].empty()) return;
  for (const bool successor : {false, true}) {
    const RoadLink& link = successor ? road.successor : road.predecessor;
    if (!link.present || link.element_type != "road") continue;
    auto other = road_of.find(link.element_id);
    if (other == road_of.end()) continue;
    const size_t own_section = successor ? sections[r].back() : sections[r].front();
    for (const Lane& l : road.sections[own_section].lanes) {
      if (!(successor ? l.has_successor : l.has_predecessor)) continue;
      const int to = successor ? l.successor : l.predecessor;
      const auto there = contact_end(other->second, sections[other->second], link.contact_point, to);
      if (there) out.insert({LaneEnd{r, own_section, l.id, successor}, *there});
    }
  }
}

// The ends (false: start, true: end) of an incoming road that meet a junction's
// connecting road: those linked to the junction or to the connecting road itself,
// else both (the geometry check in link() then decides).
std::vector<bool> ends_towards(const Road& incoming, const std::string& junction, const std::string& connecting) {
  auto meets = [&](const RoadLink& l) {
    return l.present && ((l.element_type == "junction" && l.element_id == junction) ||
                         (l.element_type == "road" && l.element_id == connecting));
  };
  std::vector<bool> ends;
  if (meets(incoming.predecessor)) ends.push_back(false);
  if (meets(incoming.successor)) ends.push_back(true);
  if (ends.empty()) ends = {false, true};
  return ends;
}

// <connection><laneLink from to> of every junction.
void junction_contacts(const Document& doc, const std::map<std::string, size_t>& road_of,
                       const std::vector<std::vector<size_t>>& sections, std::set<Contact>& out) {
  for (const Junction& j : doc.junctions)
    for (const Connection& c : j.connections) {
      auto in = road_of.find(c.incoming_road), via = road_of.find(c.connecting_road);
      if (in == road_of.end() || via == road_of.end() || sections[in->second].empty()) continue;
      const std::vector<size_t>& in_sections = sections[in->second];
      for (const bool at_end : ends_towards(doc.roads[in->second], j.id, c.connecting_road))
        for (const LaneLink& ll : c.lane_links) {
          const auto there = contact_end(via->second, sections[via->second], c.contact_point, ll.to);
          if (!there) continue;
          out.insert({LaneEnd{in->second, at_end ? in_sections.back() : in_sections.front(), ll.from, at_end}, *there});
        }
    }
}

void add_unique(std::vector<int64_t>& v, int64_t id) {
  if (std::find(v.begin(), v.end(), id) == v.end()) v.push_back(id);
}

// Links lane a to lane b when b starts near a's end without turning back.
void link(Map& map, size_t a, size_t b) {
  scene::Lane& from = map.lanes[a];
  scene::Lane& to = map.lanes[b];
  if (from.points.size() < 2 || to.points.size() < 2) return;
  if (glm::length(to.points.front() - from.points.back()) > kMaxTopologyGap) return;
  const double cos_limit = std::cos(kMaxTopologyTurnDeg * 3.14159265358979323846 / 180.0);
  if (glm::dot(lane_end_direction(from.points, true), lane_end_direction(to.points, false)) < cos_limit - 1e-12) return;
  add_unique(from.exit_lanes, to.id);
  add_unique(to.entry_lanes, from.id);
}

}  // namespace

void link_lanes_by_topology(const Document& doc, const std::vector<LaneSpan>& spans, Map& map) {
  std::map<std::string, size_t> road_of;
  for (size_t i = 0; i < doc.roads.size(); ++i) road_of.try_emplace(doc.roads[i].id, i);
  const std::vector<std::vector<size_t>> sections = sampled_sections(doc);

  std::set<Contact> contacts;
  for (size_t r = 0; r < doc.roads.size(); ++r) {
    section_contacts(doc.roads[r], r, sections[r], contacts);
    road_link_contacts(doc, r, road_of, sections, contacts);
  }
  junction_contacts(doc, road_of, sections, contacts);

  // Map lanes by the lane ends where they start and end in driving direction.
  std::map<LaneEnd, std::vector<size_t>> starts, ends;
  const size_t n = std::min(spans.size(), map.lanes.size());
  for (size_t q = 0; q < n; ++q) {
    const LaneSpan& s = spans[q];
    const LaneEnd low{s.road, s.first_section, s.first_lane, false}, high{s.road, s.last_section, s.last_lane, true};
    starts[s.backwards ? high : low].push_back(q);
    ends[s.backwards ? low : high].push_back(q);
  }
  auto connect = [&](const LaneEnd& x, const LaneEnd& y) {
    auto e = ends.find(x), s = starts.find(y);
    if (e == ends.end() || s == starts.end()) return;
    for (size_t a : e->second)
      for (size_t b : s->second) link(map, a, b);
  };
  for (const auto& [x, y] : contacts) {
    connect(x, y);
    connect(y, x);
  }
}

}  // namespace icube::scene::odr
