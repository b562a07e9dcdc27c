// OpenDRIVE reader on the real CARLA and esmini maps (shared/data, see
// PROVENANCE.md): counts, elevation, continuity, lane borders against
// hand-evaluated polynomials, superelevation, LHT, paramPoly3-only roads.
#include <doctest/doctest.h>

#include "scene/atomic_file.h"
#include "scene/opendrive/lane_borders.h"
#include "scene/opendrive/reference_line.h"
#include "scene/opendrive/road_frame.h"
#include "scene/opendrive/xodr_document.h"
#include "scene/opendrive/xodr_stats.h"
#include "test_opendrive_util.h"

#include <cmath>
#include <map>

using namespace icube::scene;
using namespace icube::test::odr_util;

namespace {

odr::Document load_doc(const std::string& path) {
  const std::string data = read_file(path);
  return odr::parse_document(data.data(), data.size(), path, nullptr);
}

#define REQUIRE_MAP(var, rel)                          \
  const std::string var = real_map(rel);               \
  if (var.empty()) {                                   \
    MESSAGE("skipped: " rel " not found (ICUBE_TEST_DATA)"); \
    return;                                            \
  }

}  // namespace

TEST_CASE("OpenDRIVE Town01: 98 roads, 12 junctions, 3.92 km of reference line") {
  REQUIRE_MAP(path, "carla/Town01.xodr");
  const odr::XodrStats st = odr::read_xodr_stats(path);
  CHECK(st.roads == 98);
  CHECK(st.junctions == 12);
  CHECK(std::fabs(st.reference_length / 1000.0 - 3.92) <= 0.01);
  CHECK(st.max_elevation == 0.0);
  CHECK(st.min_elevation == 0.0);
  Diagnostics diag;
  const Scene sc = read_opendrive(path, {}, &diag);
  MESSAGE("Town01: " << sc.map.lanes.size() << " lanes, " << sc.map.road_lines.size() << " road lines, "
                     << sc.map.road_edges.size() << " road edges, " << diag.warnings.size() << " warnings");
  CHECK(sc.provenance.source_format == "opendrive");
  CHECK(sc.provenance.source_version == "OpenDRIVE 1.4");
  CHECK(sc.map.geo_reference == "+lat_0=4.9000000000000000e+1 +lon_0=8.0000000000000000e+0");
  CHECK(sc.missing == std::vector<std::string>{"ego trajectory", "object boxes", "cameras"});
  CHECK(sc.timestamps.empty());
  CHECK(sc.tracks.empty());
  // 202 driving lanes in the file; sections of one road are joined, so fewer lanes, all street lanes
  CHECK(sc.map.lanes.size() >= 98);
  CHECK(sc.map.lanes.size() <= 202);
  size_t curbs = 0, with_exit = 0, with_speed = 0;
  for (const RoadEdge& e : sc.map.road_edges) curbs += e.type == RoadEdgeType::Curb;
  for (const Lane& l : sc.map.lanes) {
    CHECK(l.type == LaneType::SurfaceStreet);
    // roads with <type><speed max="25" unit="mph"/>; junction roads have no <type>
    CHECK((std::fabs(l.speed_limit_mph - 25.0) < 1e-9 || l.speed_limit_mph == 0.0));
    with_speed += l.speed_limit_mph > 0.0;
    with_exit += !l.exit_lanes.empty();
  }
  CHECK(curbs > 0);
  CHECK(with_speed > 50);
  // Town01 is a closed network: every lane continues into another one
  CHECK(with_exit == sc.map.lanes.size());
  // unique ids across all layers
  std::map<int64_t, int> ids;
  for (const Lane& l : sc.map.lanes) ++ids[l.id];
  for (const RoadLine& l : sc.map.road_lines) ++ids[l.id];
  for (const RoadEdge& e : sc.map.road_edges) ++ids[e.id];
  CHECK(ids.size() == sc.map.lanes.size() + sc.map.road_lines.size() + sc.map.road_edges.size());
}

TEST_CASE("OpenDRIVE Town07: record heights from -0.67 to 8.83 m, profile peak 9.40 m") {
  REQUIRE_MAP(path, "carla/Town07.xodr");
  const odr::XodrStats st = odr::read_xodr_stats(path);
  MESSAGE("Town07: " << st.roads << " roads, " << st.junctions << " junctions, elevation " << st.min_elevation << " .. "
                     << st.max_elevation << " m");
  CHECK(st.roads == 234);
  CHECK(st.junctions == 31);
  // PROVENANCE.md's 8.83 m is the highest record start value...
  CHECK(std::fabs(st.max_record_elevation - 8.83) < 0.01);
  CHECK(std::fabs(st.min_record_elevation + 0.67) < 0.01);
  // ...but road 20's record at s = 115.73 (a = 8.76857, b = 0.0820951, c = -0.0026735) peaks at its
  // vertex a + b²/(4|c|) inside the record, the true maximum.
  const double peak = 8.7685739821627884 + 8.2095067855814136e-2 * 8.2095067855814136e-2 / (4 * 2.6735034429033540e-3);
  CHECK(std::fabs(st.max_elevation - peak) < 1e-9);
  CHECK(std::fabs(st.min_elevation + 0.67) < 0.01);
  // sampled geometry reaches the same heights (reference line z is sampled every 0.25 m)
  const Scene sc = read_opendrive(path);
  double zmax = -1e9;
  for (const Lane& l : sc.map.lanes)
    for (const glm::dvec3& p : l.points) zmax = std::max(zmax, p.z);
  CHECK(zmax > 9.3);
  CHECK(zmax < 9.5);
}

TEST_CASE("OpenDRIVE continuity: consecutive geometries join within 1 cm in every real file") {
  const char* files[] = {"carla/Town01.xodr", "carla/Town02.xodr", "carla/Town07.xodr",
                         "esmini/crest-curve.xodr", "esmini/curves_elevation.xodr", "esmini/e6mini-lht.xodr",
                         "esmini/e6mini.xodr", "esmini/fabriksgatan.xodr", "esmini/four_lanes_with_offset.xodr",
                         "esmini/jolengatan.xodr", "esmini/lane_width_and_offset.xodr", "esmini/offset.xodr",
                         "esmini/straight_500_superelevation_elevation.xodr", "esmini/two_plus_one.xodr",
                         "esmini/velodrome.xodr"};
  size_t checked = 0;
  for (const char* f : files) {
    const std::string path = real_map(f);
    if (path.empty()) continue;
    const odr::XodrStats st = odr::read_xodr_stats(path);
    MESSAGE(std::string(f) << ": largest geometry gap " << st.max_gap * 1000.0 << " mm"
              << (st.max_gap_road.empty() ? std::string()
                                          : " at road " + st.max_gap_road + " geometry " +
                                                std::to_string(st.max_gap_geometry) + " (line " +
                                                std::to_string(st.max_gap_line) + ")"));
    CHECK(st.max_gap < 0.01);
    // and every file samples without error or non-finite points
    const Scene sc = read_opendrive(path);
    size_t bad = 0;
    for (const Lane& l : sc.map.lanes)
      for (const glm::dvec3& p : l.points) bad += !std::isfinite(p.x + p.y + p.z);
    CHECK(bad == 0);
    ++checked;
  }
  if (checked == 0) MESSAGE("skipped: no real OpenDRIVE files found (ICUBE_TEST_DATA)");
}

TEST_CASE("OpenDRIVE lane_width_and_offset.xodr: borders follow laneOffset s and width s") {
  REQUIRE_MAP(path, "esmini/lane_width_and_offset.xodr");
  const odr::Document doc = load_doc(path);
  REQUIRE(doc.roads.size() == 1);
  const odr::Road& r = doc.roads[0];
  std::vector<double> t;
  for (double s : {0.0, 2.5, 5.0, 7.5, 10.0}) {
    odr::section_borders(r.sections[0], r.lane_offset, s, t);
    REQUIRE(t.size() == 2);
    CHECK(std::fabs(t[0] - s) < 1e-12);        // t0 = laneOffset = 0 + 1·s
    CHECK(std::fabs(t[1] - (s - s)) < 1e-12);  // outer border of lane -1: t0 - width(s) = s - s
  }
}

TEST_CASE("OpenDRIVE four_lanes_with_offset.xodr: laneOffset 5 and widths 2, 3, 3, 2") {
  REQUIRE_MAP(path, "esmini/four_lanes_with_offset.xodr");
  const odr::Document doc = load_doc(path);
  const odr::Road& r = doc.roads.at(0);
  std::vector<double> t;
  for (double s : {0.0, 37.0, 100.0}) {
    odr::section_borders(r.sections[0], r.lane_offset, s, t);
    REQUIRE(t.size() == 5);
    const double want[] = {5.0, 3.0, 0.0, -3.0, -5.0};
    for (size_t k = 0; k < 5; ++k) CHECK(std::fabs(t[k] - want[k]) < 1e-12);
  }
  // and the sampled world points: the road runs along +x from the origin
  const Scene sc = read_opendrive(path);
  for (const Lane& l : sc.map.lanes) {
    const double y = l.points.front().y;
    CHECK((std::fabs(y - 1.5) < 1e-9 || std::fabs(y + 1.5) < 1e-9));  // mid of 3..0 and 0..-3
  }
}

TEST_CASE("OpenDRIVE offset.xodr: header offset is read but not applied; borders at +-3") {
  REQUIRE_MAP(path, "esmini/offset.xodr");
  const odr::Document doc = load_doc(path);
  CHECK(doc.header.has_offset);
  CHECK(doc.header.offset_x == -1000.0);
  CHECK(doc.header.offset_y == -500.0);
  CHECK(doc.header.offset_hdg == doctest::Approx(0.959931));
  std::vector<double> t;
  odr::section_borders(doc.roads[0].sections[0], doc.roads[0].lane_offset, 50.0, t);
  REQUIRE(t.size() == 3);
  CHECK(t[0] == 3.0);
  CHECK(t[1] == 0.0);
  CHECK(t[2] == -3.0);
  const Scene sc = read_opendrive(path);
  REQUIRE(!sc.map.road_lines.empty());
  // the centre broken line starts at the geometry's own (900, 600)
  bool found = false;
  for (const RoadLine& l : sc.map.road_lines)
    if (l.source_type == "broken standard") {
      found = true;
      CHECK(std::hypot(l.points.front().x - 900.0, l.points.front().y - 600.0) < 1e-9);
      CHECK(l.type == RoadLineType::BrokenSingleWhite);
    }
  CHECK(found);
}

TEST_CASE("OpenDRIVE straight_500_superelevation_elevation.xodr: z and roll follow their cubics") {
  REQUIRE_MAP(path, "esmini/straight_500_superelevation_elevation.xodr");
  const odr::Document doc = load_doc(path);
  const odr::Road& r = doc.roads.at(0);
  const odr::ReferenceLine line(r.geometries);
  const odr::RoadFrame frame(r, line);
  auto z_of = [](double s) {
    if (s < 250) return 0.0;
    if (s < 350) return 0.006 * (s - 250) * (s - 250) - 4e-5 * std::pow(s - 250, 3);
    if (s < 450) return 20 - 0.006 * (s - 350) * (s - 350) + 4e-5 * std::pow(s - 350, 3);
    return 0.0;
  };
  auto phi_of = [](double s) {
    if (s < 50) return 0.0;
    if (s < 150) return 0.00015 * (s - 50) * (s - 50) - 1e-6 * std::pow(s - 50, 3);
    if (s < 250) return 0.5 - 0.00015 * (s - 150) * (s - 150) + 1e-6 * std::pow(s - 150, 3);
    return 0.0;
  };
  for (double s : {0.0, 100.0, 149.0, 200.0, 275.0, 300.0, 349.0, 400.0, 480.0}) {
    const odr::FramePoint f = frame.at(s);
    CHECK(std::fabs(f.origin.z - z_of(s)) < 1e-9);
    CHECK(std::fabs(f.origin.x - s) < 1e-9);
    if (s < 250.0) {  // flat there: X(s, t) = (s, t·cos φ, t·sin φ)
      const glm::dvec3 p = frame.xyz(s, -3.07);
      CHECK(std::fabs(p.y + 3.07 * std::cos(phi_of(s))) < 1e-9);
      CHECK(std::fabs(p.z + 3.07 * std::sin(phi_of(s))) < 1e-9);
    }
  }
  // through the reader: the solid line on the outer border of lane -1 at s = 100
  const Scene sc = read_opendrive(path);
  const double phi = phi_of(100.0);
  bool found = false;
  for (const RoadLine& l : sc.map.road_lines)
    for (const glm::dvec3& p : l.points)
      if (std::fabs(p.x - 100.0) < 1e-9 && p.y < 0)
        found = found || (std::fabs(p.y + 3.07 * std::cos(phi)) < 1e-6 && std::fabs(p.z + 3.07 * std::sin(phi)) < 1e-6);
  CHECK(found);
  CHECK(sc.map.geo_reference.rfind("+proj=utm", 0) == 0);
  CHECK(sc.map.geo_reference.back() == 's');  // trimmed CDATA ends with "+no_defs"
}

TEST_CASE("OpenDRIVE e6mini-lht: every lane drives opposite to its e6mini twin") {
  REQUIRE_MAP(rht, "esmini/e6mini.xodr");
  REQUIRE_MAP(lht, "esmini/e6mini-lht.xodr");
  const Scene a = read_opendrive(rht), b = read_opendrive(lht);
  REQUIRE(a.map.lanes.size() == b.map.lanes.size());
  REQUIRE(a.map.lanes.size() == 6);
  std::map<int64_t, const Lane*> by_id;
  for (const Lane& l : b.map.lanes) by_id[l.id] = &l;
  for (const Lane& l : a.map.lanes) {
    REQUIRE(by_id.count(l.id));
    const Lane& t = *by_id[l.id];
    REQUIRE(t.points.size() == l.points.size());
    CHECK(glm::length(t.points.front() - l.points.back()) < 1e-9);
    CHECK(glm::length(t.points.back() - l.points.front()) < 1e-9);
    // RHT: right lanes (id < 0, encoded below 500) start at s = 0 near the origin
    const int lane_id = static_cast<int>(l.id % 1000) - 500;
    const bool starts_at_origin = glm::length(glm::dvec2(l.points.front())) < 20.0;
    CHECK(starts_at_origin == (lane_id < 0));
  }
  // the carriageways are separated by "border" lanes: median edges
  size_t medians = 0;
  for (const RoadEdge& e : a.map.road_edges) medians += e.type == RoadEdgeType::Median;
  CHECK(medians == 2);
}

TEST_CASE("OpenDRIVE jolengatan: paramPoly3-only roads are sampled at true arc length") {
  REQUIRE_MAP(path, "esmini/jolengatan.xodr");
  const odr::Document doc = load_doc(path);
  size_t checked = 0;
  for (const odr::Road& r : doc.roads) {
    const odr::ReferenceLine line(r.geometries);
    for (size_t i = 0; i < line.size(); ++i) {
      const odr::Geometry& g = line.piece(i).geometry();
      if (g.kind != odr::GeometryKind::ParamPoly3) continue;
      // the chord of a short step equals the step (curvature radius here >> 0.5 m)
      for (double ds = 0.0; ds + 0.5 <= g.length; ds += 7.0) {
        const odr::Pose2 p = line.piece(i).at(ds), q = line.piece(i).at(ds + 0.5);
        CHECK(std::fabs(std::hypot(q.x - p.x, q.y - p.y) - 0.5) < 1e-4);
        ++checked;
      }
      const odr::Pose2 end = line.piece(i).at(g.length);
      if (i + 1 < line.size())
        CHECK(std::hypot(end.x - line.piece(i + 1).geometry().x, end.y - line.piece(i + 1).geometry().y) < 0.01);
    }
  }
  CHECK(checked > 100);
}
