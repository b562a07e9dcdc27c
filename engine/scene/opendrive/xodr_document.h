// The parsed OpenDRIVE document: a plain mirror of the parts of a .xodr file
// the reader uses (header, roads with plan view, profiles, lane sections and
// road marks, junctions), validated but not yet evaluated.
//
// Conventions:
//  - Elements are matched by LOCAL name (a default or prefixed xmlns works);
//    <userData> and unknown elements are skipped.
//  - Every record list that is keyed by s or sOffset is sorted by that key
//    (stable, so of two records with the same s the later one wins when
//    looked up with upper_bound - 1).
//  - Lane sections hold their side lanes in one list ordered from the
//    leftmost (+t, highest id) to the rightmost (lowest id): N..1, -1..-M;
//    the centre lane (id 0) is kept apart. Border k of a section lies
//    between side lanes k-1 and k (border n_left is the centre line t0).
//  - `line` fields are 1-based XML line numbers (0 when unknown).
//  - Bad input throws InputError "<file>: <where> (line N): <what>".
#pragma once

#include "scene/input_error.h"

#include <cstddef>
#include <string>
#include <vector>

namespace icube::scene::odr {

// a + b·ds + c·ds² + d·ds³ with ds measured from `s` (or from sOffset for lane records).
struct Cubic {
  double s = 0.0, a = 0.0, b = 0.0, c = 0.0, d = 0.0;
  double value(double ds) const { return a + ds * (b + ds * (c + ds * d)); }
  double slope(double ds) const { return b + ds * (2.0 * c + ds * 3.0 * d); }
};

// Records sorted by s; the record in force at s is the last one with record.s <= s
// (the first record before its own start, evaluated at ds = 0). Empty => 0.
struct CubicProfile {
  std::vector<Cubic> records;
  const Cubic* at(double s) const;
  double value(double s) const;
  double slope(double s) const;
};

enum class GeometryKind { Line, Arc, Spiral, Poly3, ParamPoly3 };

struct Geometry {
  double s = 0.0, x = 0.0, y = 0.0, hdg = 0.0, length = 0.0;
  GeometryKind kind = GeometryKind::Line;
  double curvature = 0.0;                  // arc
  double curv_start = 0.0, curv_end = 0.0; // spiral
  double a = 0.0, b = 0.0, c = 0.0, d = 0.0;  // poly3 v(u)
  double au = 0.0, bu = 0.0, cu = 0.0, du = 0.0, av = 0.0, bv = 0.0, cv = 0.0, dv = 0.0;  // paramPoly3
  bool normalized = false;  // paramPoly3 pRange="normalized" (p in [0,1]) vs "arcLength" (p in [0,length])
  int line = 0;
};

struct RoadLink {
  bool present = false;
  std::string element_type;   // "road" or "junction"
  std::string element_id;
  std::string contact_point;  // "start", "end" or empty
};

// <roadMark><type><line .../></type>: the explicit line layout of a mark.
struct RoadMarkLine {
  double length = 0.0, space = 0.0, t_offset = 0.0, s_offset = 0.0, width = 0.0;
  std::string rule, color;
};

struct RoadMark {
  double s_offset = 0.0;
  std::string type = "none";     // solid, broken, "solid solid", ..., curb, grass, none
  std::string color = "standard";
  std::string weight = "standard";
  double width = 0.0;            // 0 when absent
  std::string explicit_name;     // <type name=...>, empty when absent
  std::vector<RoadMarkLine> lines;
  int line = 0;
};

struct LaneHeight {
  double s_offset = 0.0, inner = 0.0, outer = 0.0;
};

struct Lane {
  int id = 0;
  std::string type = "none";
  bool level = false;
  std::vector<Cubic> widths;   // Cubic::s = sOffset
  std::vector<Cubic> borders;  // Cubic::s = sOffset; used only when widths is empty (ASAM rule)
  std::vector<RoadMark> marks; // sorted by sOffset
  std::vector<LaneHeight> heights;
  bool has_predecessor = false, has_successor = false;
  int predecessor = 0, successor = 0;
  double speed_mps = -1.0;     // first lane <speed>, -1 when none
  int line = 0;
};

struct LaneSection {
  double s = 0.0;
  bool single_side = false;
  std::vector<Lane> lanes;  // side lanes, leftmost first: N..1, -1..-M
  size_t n_left = 0;        // lanes[0..n_left) are left lanes (id > 0)
  Lane center;              // id 0 (synthesised with type "none" when absent)
  int line = 0;
  size_t border_count() const { return lanes.size() + 1; }
};

struct RoadType {
  double s = 0.0;
  std::string type;       // "town", "motorway", ...
  double speed_mps = -1.0;  // <speed max unit>, -1 when none or "no limit"
};

struct Road {
  std::string id, name;
  std::string junction = "-1";
  double length = 0.0;
  bool lht = false;  // rule="LHT"
  RoadLink predecessor, successor;
  std::vector<RoadType> types;         // sorted by s
  std::vector<Geometry> geometries;    // sorted by s
  CubicProfile elevation, superelevation, lane_offset;
  std::vector<LaneSection> sections;   // sorted by s
  int line = 0;
  bool in_junction() const { return junction != "-1" && !junction.empty(); }
};

struct LaneLink {
  int from = 0, to = 0;
};

struct Connection {
  std::string id, incoming_road, connecting_road, contact_point;
  std::vector<LaneLink> lane_links;
};

struct Junction {
  std::string id, name;
  std::vector<Connection> connections;
  int line = 0;
};

struct Header {
  int rev_major = 1, rev_minor = 4;
  std::string name, vendor;
  std::string geo_reference;  // trimmed text/CDATA of <geoReference>, empty when absent
  bool has_offset = false;    // <offset x y z hdg> (1.7+): kept, not applied to coordinates
  double offset_x = 0.0, offset_y = 0.0, offset_z = 0.0, offset_hdg = 0.0;
};

struct Document {
  std::string file;
  Header header;
  std::vector<Road> roads;
  std::vector<Junction> junctions;
};

// Limits beyond which input is rejected as absurd.
inline constexpr double kMaxLength = 1.0e6;       // metres, per road or geometry
inline constexpr double kMaxCoordinate = 1.0e9;   // metres, |x|, |y|, |z| of a record
inline constexpr double kMaxCurvature = 1.0e5;    // 1/m
inline constexpr int kMaxLaneId = 499;

// Parses and validates the XML. `file` names the input in errors and warnings.
Document parse_document(const char* xml, size_t size, const std::string& file, Diagnostics* diag);

}  // namespace icube::scene::odr
