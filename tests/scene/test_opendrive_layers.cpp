// OpenDRIVE layers on synthetic documents: road-mark types and splits, edge
// classes, junction union edges, lane directions and links, and the input
// quirks of real files (default namespace, string ids, out-of-order records,
// 6.7e-5 m geometries, <userData>).
#include <doctest/doctest.h>

#include "scene/opendrive/junction_edges.h"
#include "test_opendrive_util.h"

#include <cmath>

using namespace icube::scene;
using namespace icube::test::odr_util;

namespace {

constexpr double kHalfPi = 1.5707963267948966;

std::string line_geom(double s, double x, double y, double hdg, double len) {
  return "<geometry s=\"" + std::to_string(s) + "\" x=\"" + std::to_string(x) + "\" y=\"" + std::to_string(y) +
         "\" hdg=\"" + std::to_string(hdg) + "\" length=\"" + std::to_string(len) + "\"><line/></geometry>";
}

const RoadLine* line_of(const Scene& sc, const std::string& source_type) {
  for (const RoadLine& l : sc.map.road_lines)
    if (l.source_type == source_type) return &l;
  return nullptr;
}

// A 4-arm crossing: connecting roads EW (x -10..10) and NS (y -10..10) in junction 7, four incoming roads.
std::string crossing(const std::string& root_attrs = "") {
  auto arm = [](const std::string& id, double x, double y, double hdg, const std::string& link) {
    return road_xml(id, 20.0, line_geom(0, x, y, hdg, 20.0), two_lane_section(3.5), "<link>" + link + "</link>");
  };
  std::string body;
  body += arm("west", -30, 0, 0, "<successor elementType=\"junction\" elementId=\"7\"/>");
  body += arm("east", 10, 0, 0, "<predecessor elementType=\"junction\" elementId=\"7\"/>");
  body += arm("south", 0, -30, kHalfPi, "<successor elementType=\"junction\" elementId=\"7\"/>");
  body += arm("north", 0, 10, kHalfPi, "<predecessor elementType=\"junction\" elementId=\"7\"/>");
  auto conn = [](const std::string& id, double x, double y, double hdg, const std::string& from, const std::string& to) {
    return road_xml(id, 20.0, line_geom(0, x, y, hdg, 20.0), two_lane_section(3.5),
                    "<link><predecessor elementType=\"road\" elementId=\"" + from +
                        "\" contactPoint=\"end\"/><successor elementType=\"road\" elementId=\"" + to +
                        "\" contactPoint=\"start\"/></link>",
                    "junction=\"7\"");
  };
  body += conn("c-ew", -10, 0, 0, "west", "east");
  body += conn("c-ns", 0, -10, kHalfPi, "south", "north");
  body += "<junction id=\"7\" name=\"x\"><connection id=\"0\" incomingRoad=\"west\" connectingRoad=\"c-ew\" "
          "contactPoint=\"start\"><laneLink from=\"-1\" to=\"-1\"/></connection><connection id=\"1\" "
          "incomingRoad=\"south\" connectingRoad=\"c-ns\" contactPoint=\"start\"/></junction>\n";
  return document(body, root_attrs);
}

}  // namespace

TEST_CASE("OpenDRIVE road marks map to Waymo line types and split where the type changes") {
  const std::string lanes =
      "<laneSection s=\"0\"><left><lane id=\"1\" type=\"driving\"><width sOffset=\"0\" a=\"3\"/>"
      "<roadMark sOffset=\"0\" type=\"solid solid\" color=\"yellow\"/></lane></left>"
      "<center><lane id=\"0\" type=\"none\"><roadMark sOffset=\"0\" type=\"solid\" color=\"white\"/>"
      "<roadMark sOffset=\"40\" type=\"broken\" color=\"standard\"/><roadMark sOffset=\"60\" type=\"none\"/>"
      "<roadMark sOffset=\"70\" type=\"broken solid\" color=\"yellow\"/></lane></center>"
      "<right><lane id=\"-1\" type=\"driving\"><width sOffset=\"0\" a=\"3\"/>"
      "<roadMark sOffset=\"0\" type=\"curb\"/></lane><lane id=\"-2\" type=\"sidewalk\"><width sOffset=\"0\" a=\"2\"/>"
      "<roadMark sOffset=\"0\" type=\"broken broken\" color=\"white\"/></lane></right></laneSection>";
  const Scene sc = parse(document(road_xml("r", 100.0, line_geom(0, 0, 0, 0, 100), lanes)));
  REQUIRE(sc.map.road_lines.size() == 5);
  const RoadLine* solid = line_of(sc, "solid white");
  const RoadLine* broken = line_of(sc, "broken standard");
  const RoadLine* passing = line_of(sc, "broken solid yellow");
  const RoadLine* dbl = line_of(sc, "solid solid yellow");
  const RoadLine* bb = line_of(sc, "broken broken white");
  REQUIRE((solid && broken && passing && dbl && bb));
  CHECK(solid->type == RoadLineType::SolidSingleWhite);
  CHECK(broken->type == RoadLineType::BrokenSingleWhite);
  CHECK(passing->type == RoadLineType::PassingDoubleYellow);
  CHECK(dbl->type == RoadLineType::SolidDoubleYellow);
  CHECK(bb->type == RoadLineType::BrokenSingleWhite);
  // exact split points along +s, centre mark at t0 = 0, left mark at t = 3
  CHECK(solid->points.front() == glm::dvec3(0, 0, 0));
  CHECK(solid->points.back() == glm::dvec3(40, 0, 0));
  CHECK(broken->points.front() == glm::dvec3(40, 0, 0));
  CHECK(broken->points.back() == glm::dvec3(60, 0, 0));
  CHECK(passing->points.front() == glm::dvec3(70, 0, 0));
  CHECK(passing->points.back() == glm::dvec3(100, 0, 0));
  CHECK(dbl->points.front().y == 3.0);
  CHECK(bb->points.front().y == -5.0);
  CHECK(broken->points.size() == 81);
  // the curb: a Curb edge on the border between the driving lane and the sidewalk
  size_t curbs = 0;
  for (const RoadEdge& e : sc.map.road_edges)
    if (e.type == RoadEdgeType::Curb) {
      ++curbs;
      CHECK(e.points.front().y == -3.0);
      CHECK(e.points.back() == glm::dvec3(100, -3, 0));
    }
  CHECK(curbs == 1);
}

TEST_CASE("OpenDRIVE road edges: boundary at drivable/non-drivable borders, median between carriageways") {
  const std::string lanes =
      "<laneSection s=\"0\"><left><lane id=\"3\" type=\"sidewalk\"><width sOffset=\"0\" a=\"2\"/></lane>"
      "<lane id=\"2\" type=\"driving\"><width sOffset=\"0\" a=\"3\"/></lane>"
      "<lane id=\"1\" type=\"median\"><width sOffset=\"0\" a=\"1\"/></lane></left>"
      "<center><lane id=\"0\" type=\"none\"/></center>"
      "<right><lane id=\"-1\" type=\"driving\"><width sOffset=\"0\" a=\"3\"/></lane>"
      "<lane id=\"-2\" type=\"driving\"><width sOffset=\"0\" a=\"0\"/></lane>"  // zero width: transparent
      "</right></laneSection>";
  const Scene sc = parse(document(road_xml("r", 50.0, line_geom(0, 0, 0, 0, 50), lanes)));
  std::vector<std::pair<RoadEdgeType, double>> got;
  for (const RoadEdge& e : sc.map.road_edges) got.push_back({e.type, e.points.front().y});
  std::sort(got.begin(), got.end(), [](auto& a, auto& b) { return a.second > b.second; });
  REQUIRE(got.size() == 4);
  CHECK(got[0] == std::make_pair(RoadEdgeType::Boundary, 4.0));  // driving | sidewalk
  CHECK(got[1] == std::make_pair(RoadEdgeType::Median, 1.0));    // driving | median (left carriageway)
  CHECK(got[2] == std::make_pair(RoadEdgeType::Median, 0.0));    // median | driving (right carriageway)
  CHECK(got[3] == std::make_pair(RoadEdgeType::Boundary, -3.0)); // outer side (the 0-width lane drawn once)
  for (const RoadEdge& e : sc.map.road_edges) CHECK(e.points.size() == 201);
}

TEST_CASE("OpenDRIVE lanes drive along +s on the right, against it on the left, flipped by rule=LHT") {
  for (bool lht : {false, true}) {
    const std::string attrs = std::string("junction=\"-1\"") + (lht ? " rule=\"LHT\"" : "");
    const Scene sc = parse(document(road_xml("r", 30.0, line_geom(0, 0, 0, 0, 30), two_lane_section(3.0), "", attrs)));
    REQUIRE(sc.map.lanes.size() == 2);
    for (const Lane& l : sc.map.lanes) {
      const bool right = l.points.front().y < 0;
      const bool along_s = l.points.front().x < l.points.back().x;
      CHECK(along_s == (right != lht));
      CHECK(std::fabs(std::fabs(l.points.front().y) - 1.5) < 1e-12);
      CHECK(l.type == LaneType::SurfaceStreet);
    }
  }
}

TEST_CASE("OpenDRIVE junction edges come from the union of drivable areas") {
  OpenDriveOptions per_road;
  per_road.junction_union_edges = false;
  const Scene uni = parse(crossing()), sep = parse(crossing(), per_road);
  // strictly inside the plus-shaped drivable union (arms of half-width 3.5 m, 0.2 m margin)
  auto inside_union = [](const glm::dvec3& p) {
    return (std::fabs(p.x) < 3.3 && std::fabs(p.y) < 9.8) || (std::fabs(p.y) < 3.3 && std::fabs(p.x) < 9.8);
  };
  auto in_box = [](const RoadEdge& e) {
    for (const glm::dvec3& p : e.points)
      if (std::fabs(p.x) > 10.5 || std::fabs(p.y) > 10.5) return false;
    return true;
  };
  // per-road edges of one connecting road cross the other one's drivable area
  size_t crossing_points = 0;
  for (const RoadEdge& e : sep.map.road_edges)
    for (const glm::dvec3& p : e.points) crossing_points += inside_union(p);
  CHECK(crossing_points > 0);
  // union edges: none inside the drivable area; all on the plus shape's outline |x| = 3.5 or |y| = 3.5
  double length = 0.0;
  size_t union_edges = 0;
  for (const RoadEdge& e : uni.map.road_edges) {
    if (!in_box(e)) continue;  // the incoming roads' own edges run out to +-30 m
    ++union_edges;
    CHECK(e.type == RoadEdgeType::Boundary);
    for (size_t i = 0; i < e.points.size(); ++i) {
      const glm::dvec3& p = e.points[i];
      CHECK(!inside_union(p));
      CHECK(std::min(std::fabs(std::fabs(p.x) - 3.5), std::fabs(std::fabs(p.y) - 3.5)) < 0.15);
      if (i > 0) length += glm::length(p - e.points[i - 1]);
    }
  }
  MESSAGE("junction union: " << union_edges << " edges, " << length << " m");
  CHECK(union_edges == 4);
  CHECK(std::fabs(length - 8 * 6.5) < 3.0);  // four corners, each 2 × (10 − 3.5) m
}

TEST_CASE("OpenDRIVE junction whose incoming road lies 9e7 m away: its quads fall outside the junction raster") {
  // The "west" arm claims junction 7 as its successor but lies 9e7 m west: its drivable quads are
  // rasterised into a grid that spans only the connecting roads (cell indices near -6e8).
  const auto arm = [](const std::string& id, double x, double y, double hdg, const std::string& link) {
    return road_xml(id, 20.0, line_geom(0, x, y, hdg, 20.0), two_lane_section(3.5), "<link>" + link + "</link>");
  };
  std::string body = arm("west", -9e7, 0, 0, "<successor elementType=\"junction\" elementId=\"7\"/>");
  body += arm("east", 10, 0, 0, "<predecessor elementType=\"junction\" elementId=\"7\"/>");
  body += road_xml("c-ew", 20.0, line_geom(0, -10, 0, 0, 20.0), two_lane_section(3.5),
                   "<link><predecessor elementType=\"road\" elementId=\"west\" contactPoint=\"end\"/>"
                   "<successor elementType=\"road\" elementId=\"east\" contactPoint=\"start\"/></link>",
                   "junction=\"7\"");
  body += "<junction id=\"7\" name=\"x\"/>\n";
  const Scene sc = parse(document(body));
  // the union outline of the connecting road alone: a 20 x 7 m rectangle, open where "east" enters
  size_t near = 0;
  for (const RoadEdge& e : sc.map.road_edges) {
    if (std::fabs(e.points.front().x) > 1e6) continue;  // the far road's own edges
    for (const glm::dvec3& p : e.points) {
      CHECK(std::fabs(p.y) < 3.7);
      CHECK(p.x > -10.8);
      CHECK(p.x < 30.2);
    }
    ++near;
  }
  CHECK(near > 0);
}

TEST_CASE("OpenDRIVE junction raster cell: real junctions keep 0.15 m, folded strips coarsen to the visit budget") {
  using icube::scene::odr::junction_raster_cell;
  using icube::scene::odr::kCellSize;
  using icube::scene::odr::kFillVisitsPerCell;
  // fabriksgatan's junction 4 (the largest fill ratio of the real maps): 8.6-fold box overlap
  const double bw = 40.0, bh = 40.0;
  CHECK(junction_raster_cell(bw, bh, 8.6 * bw * bh, 10.0 * bw * bh, 4.0e6) == kCellSize);
  // a 4e6-cell budget shared by many junctions: the grid budget alone decides
  const double grid_only = junction_raster_cell(bw, bh, 8.6 * bw * bh, 10.0 * bw * bh, 1.0e4);
  CHECK(grid_only > kCellSize);
  CHECK((bw / grid_only + 3.0) * (bh / grid_only + 3.0) <= 1.0e4);
  CHECK((bw / (grid_only / 1.1) + 3.0) * (bh / (grid_only / 1.1) + 3.0) > 1.0e4);
  // strips covering their 126 m box 2e5 times over: the fill visits decide, at the 1.1x step that meets them
  const double fw = 126.0, area = 2.0e5 * fw * fw, side = 2.0e5 * 2.0 * fw;
  const double folded = junction_raster_cell(fw, fw, area, side, 4.0e6);
  const auto visits = [&](double c) { return area / (c * c) + side / c; };
  MESSAGE("folded strips: " << folded << " m cells, " << visits(folded) << " fill visits");
  CHECK(visits(folded) <= kFillVisitsPerCell * 4.0e6);
  CHECK(visits(folded / 1.1) > kFillVisitsPerCell * 4.0e6);
  CHECK((fw / folded + 3.0) * (fw / folded + 3.0) <= 4.0e6);
}

TEST_CASE("OpenDRIVE junction with a 61 m lane on a 0.2-0.5 m radius spiral: the raster coarsens, edges stay in its box") {
  // Found by fuzz_opendrive: 20 km of a 61 m wide lane wound on a spiral of radius 0.2-0.5 m. Its
  // quads each cover most of the 124 m junction box, so filling them at 0.15 m cells visited ~1e10
  // cells (past the fuzzer's 30 s timeout); the fill visits now bound the cell size.
  const std::string lanes = "<laneSection s=\"0\"><center><lane id=\"0\" type=\"none\"/></center><right>"
                            "<lane id=\"-1\" type=\"driving\"><width sOffset=\"0\" a=\"61\" b=\"0\" c=\"0\" d=\"0\"/>"
                            "</lane></right></laneSection>";
  const std::string plan = "<geometry s=\"0\" x=\"1\" y=\"1\" hdg=\"0\" length=\"20000\">"
                           "<spiral curvStart=\"5\" curvEnd=\"2\"/></geometry>";
  const std::string body = road_xml("coil", 20000.0, plan, lanes, "", "junction=\"7\"") + "<junction id=\"7\" name=\"x\"/>\n";
  Diagnostics diag;
  const Scene sc = parse(document(body), {}, &diag);
  bool coarsened = false;
  for (const std::string& w : diag.warnings) coarsened |= w.find("junction 7") != std::string::npos &&
                                                            w.find("coarsened") != std::string::npos;
  CHECK(coarsened);
  size_t edges = 0;
  for (const RoadEdge& e : sc.map.road_edges)
    for (const glm::dvec3& p : e.points) {
      ++edges;
      CHECK(std::fabs(p.x - 1.0) < 80.0);
      CHECK(std::fabs(p.y - 1.0) < 80.0);
    }
  CHECK(edges > 0);
}

TEST_CASE("OpenDRIVE lane graph links incoming, connecting and outgoing lanes") {
  const Scene sc = parse(crossing());
  const Lane* west_right = nullptr;
  const Lane* ew_right = nullptr;
  for (const Lane& l : sc.map.lanes) {
    if (l.points.front() == glm::dvec3(-30, -1.75, 0)) west_right = &l;
    if (l.points.front() == glm::dvec3(-10, -1.75, 0)) ew_right = &l;
  }
  REQUIRE(west_right);
  REQUIRE(ew_right);
  CHECK(west_right->exit_lanes == std::vector<int64_t>{ew_right->id});
  CHECK(ew_right->entry_lanes == std::vector<int64_t>{west_right->id});
}

TEST_CASE("OpenDRIVE default namespace, prefixes and <userData> do not change the result") {
  const Scene plain = parse(crossing());
  const Scene ns = parse(crossing(" xmlns=\"http://www.opendrive.org\""));
  CHECK(ns.map.lanes.size() == plain.map.lanes.size());
  CHECK(ns.map.road_edges.size() == plain.map.road_edges.size());
  CHECK(ns.map.road_lines.size() == plain.map.road_lines.size());
  CHECK(plain.map.lanes.size() == 12);
  std::string prefixed = "<?xml version=\"1.0\"?><odr:OpenDRIVE xmlns:odr=\"http://www.opendrive.org\"><odr:header/>" +
                         road_xml("r", 10.0, line_geom(0, 0, 0, 0, 10), two_lane_section()) + "</odr:OpenDRIVE>";
  for (const char* name : {"road", "planView", "geometry", "line", "lanes", "laneSection", "left", "right", "center",
                           "lane", "width", "roadMark"}) {
    const std::string tag(name);
    for (const std::string& open :
         std::vector<std::string>{"<" + tag + " ", "<" + tag + ">", "<" + tag + "/>", "</" + tag + ">"}) {
      const std::string with = open.substr(0, open[1] == '/' ? 2 : 1) + "odr:" + open.substr(open[1] == '/' ? 2 : 1);
      for (size_t pos = prefixed.find(open); pos != std::string::npos; pos = prefixed.find(open, pos + with.size()))
        prefixed.replace(pos, open.size(), with);
    }
  }
  // userData with look-alike children is skipped
  prefixed.insert(prefixed.find("<odr:planView>") + 14,
                  "<userData><geometry s=\"0\" x=\"1e3\" y=\"0\" hdg=\"0\" length=\"5\"><line/></geometry></userData>");
  const Scene p = parse(prefixed);
  CHECK(p.map.lanes.size() == 2);
  CHECK(p.map.road_lines.size() == 1);
}

TEST_CASE("OpenDRIVE string road ids, out-of-order elevation records and a 6.7e-5 m geometry") {
  const std::string plan = line_geom(0, 0, 0, 0, 20) + line_geom(20, 20, 0, 0, 6.7e-5) + line_geom(20.000067, 20.000067, 0, 0, 10);
  const std::string extra = "<elevationProfile><elevation s=\"15\" a=\"1.5\" b=\"0.1\" c=\"0\" d=\"0\"/>"
                            "<elevation s=\"0\" a=\"0\" b=\"0.1\" c=\"0\" d=\"0\"/></elevationProfile>";
  const std::string body = road_xml("Main Street-2", 30.000067, plan, two_lane_section(3.0), extra);
  Diagnostics diag;
  const Scene sc = parse(document(body), {}, &diag);
  CHECK(diag.warnings.empty());
  REQUIRE(sc.map.lanes.size() == 2);
  for (const Lane& l : sc.map.lanes) {
    for (const glm::dvec3& p : l.points) {
      CHECK(std::isfinite(p.x + p.y + p.z));
      CHECK(std::fabs(p.z - 0.1 * p.x) < 1e-9);  // z = 0.1·s on both records, whatever their order
    }
    for (size_t i = 1; i < l.points.size(); ++i) CHECK(glm::length(glm::dvec2(l.points[i] - l.points[i - 1])) <= 0.25 + 1e-9);
  }
  // the tiny geometry's start and end are samples
  bool start = false, end = false;
  for (const glm::dvec3& p : sc.map.lanes[0].points) {
    start = start || std::fabs(p.x - 20.0) < 1e-12;
    end = end || std::fabs(p.x - 20.000067) < 1e-12;
  }
  CHECK((start && end));
}
