// read_opendrive / parse_opendrive (scene/opendrive_reader.h): parse the
// document, sample every road, derive lanes, road lines and road edges
// (per road, or from the union of drivable areas inside junctions), link
// lanes (by the document's road, lane and junction links, lane_topology.h,
// then by geometry for lanes left without an exit), and fill provenance.
// Rejects maps that would need more than options.max_points samples, and
// roads whose geometry evaluates to non-finite points or to points more than
// kMaxCoordinate from the origin.
#include "scene/opendrive_reader.h"

#include "scene/atomic_file.h"
#include "scene/opendrive/junction_edges.h"
#include "scene/opendrive/lane_topology.h"
#include "scene/opendrive/layers.h"
#include "scene/opendrive/reference_line.h"
#include "scene/opendrive/road_sampling.h"
#include "scene/opendrive/xodr_document.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <utility>

namespace icube::scene {

namespace {

// 1e8 m (100,000 km) holds any projected coordinate on Earth (UTM northings stay under 1e7 m) and
// keeps every grid index the layers derive from a point (lane-link cells, junction rasters) in range.
constexpr double kMaxCoordinate = 1.0e8;

std::string road_where(const odr::Road& road) { return "road " + road.id + " (line " + std::to_string(road.line) + ")"; }

bool finite(const glm::dvec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }
bool in_range(const glm::dvec3& p) {
  return std::abs(p.x) <= kMaxCoordinate && std::abs(p.y) <= kMaxCoordinate && std::abs(p.z) <= kMaxCoordinate;
}

void check_points(const std::string& file, const odr::Road& road, const std::vector<odr::SectionSamples>& samples) {
  for (const odr::SectionSamples& ss : samples)
    for (size_t i = 0; i < ss.s.size(); ++i)
      for (size_t k = 0; k < ss.borders; ++k) {
        const glm::dvec3 p = ss.point(i, k);
        if (!finite(p))
          throw InputError(file, road_where(road),
                           "lane border " + std::to_string(k) + " evaluates to a non-finite point at s = " +
                               std::to_string(ss.s[i]));
        if (!in_range(p)) {
          char at[160];
          std::snprintf(at, sizeof at, "reaches (%.4g, %.4g, %.4g) at s = %.6g", p.x, p.y, p.z, ss.s[i]);
          throw InputError(file, road_where(road),
                           "lane border " + std::to_string(k) + " " + at + ", more than 1e8 m from the origin");
        }
      }
}

// Which junction areas each road touches as an incoming road, and at which end (0 start, 1 end).
using IncomingEnds = std::vector<std::set<std::pair<size_t, int>>>;

}  // namespace

Scene parse_opendrive(const char* xml, size_t size, const std::string& file, const OpenDriveOptions& options,
                      Diagnostics* diag) {
  if (!(options.sample_step >= 1e-3 && options.sample_step <= 1e3))
    throw InputError(file, "options", "sample_step must be in [0.001, 1000] m, got " + std::to_string(options.sample_step));
  if (!(options.max_points >= 1.0 && options.max_points <= 1.0e9))
    throw InputError(file, "options", "max_points must be in [1, 1e9], got " + std::to_string(options.max_points));
  const odr::Document doc = odr::parse_document(xml, size, file, diag);

  Scene scene;
  scene.provenance.source_file = file;
  scene.provenance.source_format = "opendrive";
  scene.provenance.scenario_id = doc.header.name;
  scene.provenance.source_version =
      "OpenDRIVE " + std::to_string(doc.header.rev_major) + "." + std::to_string(doc.header.rev_minor);
  scene.map.geo_reference = doc.header.geo_reference;
  scene.missing = {"ego trajectory", "object boxes", "cameras"};

  double points = 0.0;
  for (const odr::Road& road : doc.roads) points += odr::estimate_points(road, options.sample_step);
  if (points > options.max_points) {
    char limit[32];
    std::snprintf(limit, sizeof limit, "%.3g", options.max_points);
    throw InputError(file, "", "map needs about " + std::to_string(static_cast<long long>(points)) +
                                   " samples at a step of " + std::to_string(options.sample_step) +
                                   " m, more than the limit of " + limit);
  }

  // Junction areas and the road ends that enter them.
  std::map<std::string, size_t> area_of;
  std::vector<odr::JunctionArea> areas;
  auto area = [&](const std::string& id) {
    auto [it, fresh] = area_of.try_emplace(id, areas.size());
    if (fresh) areas.push_back({id, {}, {}});
    return it->second;
  };
  for (const odr::Junction& j : doc.junctions) area(j.id);
  std::map<std::string, size_t> road_of;
  for (size_t i = 0; i < doc.roads.size(); ++i) road_of.try_emplace(doc.roads[i].id, i);
  IncomingEnds incoming(doc.roads.size());
  const bool union_edges = options.junction_union_edges;
  if (union_edges) {
    for (size_t i = 0; i < doc.roads.size(); ++i) {
      const odr::Road& r = doc.roads[i];
      if (r.in_junction()) {
        const size_t a = area(r.junction);
        for (const odr::RoadLink* l : {&r.predecessor, &r.successor}) {
          if (!l->present || l->element_type != "road") continue;
          auto it = road_of.find(l->element_id);
          if (it == road_of.end() || doc.roads[it->second].in_junction()) continue;
          if (l->contact_point == "start") incoming[it->second].insert({a, 0});
          else if (l->contact_point == "end") incoming[it->second].insert({a, 1});
        }
      } else {
        if (r.predecessor.present && r.predecessor.element_type == "junction")
          incoming[i].insert({area(r.predecessor.element_id), 0});
        if (r.successor.present && r.successor.element_type == "junction")
          incoming[i].insert({area(r.successor.element_id), 1});
      }
    }
  }

  int64_t next_line = 1, next_edge = 1;
  std::vector<odr::LaneSpan> lane_spans;  // parallel to scene.map.lanes
  for (size_t i = 0; i < doc.roads.size(); ++i) {
    const odr::Road& road = doc.roads[i];
    const odr::ReferenceLine line = [&] {
      try {
        return odr::ReferenceLine(road.geometries);
      } catch (const odr::GeometryError& e) {
        throw InputError(file,
                         "road " + road.id + " geometry " + std::to_string(e.index) + " (line " + std::to_string(e.line) + ")",
                         e.what());
      }
    }();
    const std::vector<odr::SectionSamples> samples = odr::sample_road(road, line, options.sample_step);
    check_points(file, road, samples);
    odr::emit_road_lines(road, samples, scene.map, next_line);
    odr::emit_lanes(road, i, samples, scene.map, lane_spans);
    if (union_edges && road.in_junction())
      odr::drivable_quads(road, samples, options.drivable_lane_types, -1, 0.0, areas[area(road.junction)].connecting);
    else
      odr::emit_road_edges(road, samples, options.drivable_lane_types, scene.map, next_edge);
    for (const auto& [a, end] : incoming[i])
      odr::drivable_quads(road, samples, options.drivable_lane_types, end, odr::kIncomingReach, areas[a].incoming);
  }
  if (union_edges) {
    size_t used = 0;
    for (const odr::JunctionArea& a : areas) used += !a.connecting.empty();
    const double budget = std::min(4.0e6, 3.2e7 / static_cast<double>(std::max<size_t>(used, 1)));
    for (const odr::JunctionArea& a : areas) odr::junction_union_edges(a, scene.map, next_edge, file, diag, budget);
  }
  odr::link_lanes_by_topology(doc, lane_spans, scene.map);
  odr::link_lanes(scene.map);
  return scene;
}

Scene read_opendrive(const std::string& path, const OpenDriveOptions& options, Diagnostics* diag) {
  const std::string data = read_file(path);
  return parse_opendrive(data.data(), data.size(), path, options, diag);
}

}  // namespace icube::scene
