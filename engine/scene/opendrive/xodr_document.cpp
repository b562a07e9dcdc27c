// Parses a .xodr buffer into odr::Document (see xodr_document.h): strict
// attribute checks with XML line numbers, records sorted by s, side lanes
// ordered leftmost first.
#include "scene/opendrive/xodr_document.h"

#include "scene/opendrive/xodr_xml.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace icube::scene::odr {

const Cubic* CubicProfile::at(double s) const {
  if (records.empty()) return nullptr;
  auto it = std::upper_bound(records.begin(), records.end(), s, [](double v, const Cubic& c) { return v < c.s; });
  return it == records.begin() ? &records.front() : &*(it - 1);
}

double CubicProfile::value(double s) const {
  const Cubic* c = at(s);
  return c ? c->value(std::max(0.0, s - c->s)) : 0.0;
}

double CubicProfile::slope(double s) const {
  const Cubic* c = at(s);
  return c ? c->slope(std::max(0.0, s - c->s)) : 0.0;
}

namespace {

template <class T, class Key>
void sort_by(std::vector<T>& v, Key key) {
  std::stable_sort(v.begin(), v.end(), [&](const T& a, const T& b) { return key(a) < key(b); });
}

double speed_to_mps(const XmlSource& src, const pugi::xml_node& n, const std::string& where) {
  const std::string max = src.string_or(n, "max", "");
  if (max.empty() || max == "no limit" || max == "undefined") return -1.0;
  const double v = src.number(n, "max", where);
  const std::string unit = src.string_or(n, "unit", "m/s");
  if (unit == "km/h") return v / 3.6;
  if (unit == "mph") return v * 0.44704;
  if (unit != "m/s") src.warn(n, where, "unknown speed unit '" + unit + "'; assuming m/s");
  return v;
}

class Parser {
 public:
  Parser(const XmlSource& src, Document& doc) : src_(src), doc_(doc) {}

  void header(const pugi::xml_node& n) {
    Header& h = doc_.header;
    const std::string where = "header";
    if (!n.attribute("revMajor") || !n.attribute("revMinor"))
      src_.warn(n, where, "missing revMajor/revMinor; assuming OpenDRIVE 1.4");
    h.rev_major = n.attribute("revMajor") ? src_.integer(n, "revMajor", where) : 1;
    h.rev_minor = n.attribute("revMinor") ? src_.integer(n, "revMinor", where) : 4;
    h.name = src_.string_or(n, "name", "");
    h.vendor = src_.string_or(n, "vendor", "");
    if (pugi::xml_node g = child_named(n, "geoReference")) h.geo_reference = element_text(g);
    if (pugi::xml_node o = child_named(n, "offset")) {
      h.has_offset = true;
      h.offset_x = src_.number_or(o, "x", 0.0, "header offset");
      h.offset_y = src_.number_or(o, "y", 0.0, "header offset");
      h.offset_z = src_.number_or(o, "z", 0.0, "header offset");
      h.offset_hdg = src_.number_or(o, "hdg", 0.0, "header offset");
    }
  }

  Road road(const pugi::xml_node& n, size_t index) {
    Road r;
    r.line = src_.line_of(n);
    if (!n.attribute("id")) src_.fail(n, "road #" + std::to_string(index), "missing attribute 'id'");
    r.id = src_.string(n, "id", "road #" + std::to_string(index));
    const std::string where = "road " + r.id;
    r.name = src_.string_or(n, "name", "");
    r.junction = src_.string_or(n, "junction", "-1");
    r.length = src_.number(n, "length", where);
    if (r.length < 0.0) src_.fail(n, where, "negative length " + std::to_string(r.length));
    if (r.length > kMaxLength) src_.fail(n, where, "length " + std::to_string(r.length) + " m exceeds 1e6 m");
    const std::string rule = src_.string_or(n, "rule", "RHT");
    r.lht = rule == "LHT" || rule == "lht";
    if (pugi::xml_node link = child_named(n, "link")) {
      r.predecessor = road_link(child_named(link, "predecessor"));
      r.successor = road_link(child_named(link, "successor"));
    }
    for (const pugi::xml_node& t : children_named(n, "type")) {
      RoadType rt;
      rt.s = src_.number_or(t, "s", 0.0, where + " type");
      rt.type = src_.string_or(t, "type", "");
      if (pugi::xml_node sp = child_named(t, "speed")) rt.speed_mps = speed_to_mps(src_, sp, where + " type speed");
      r.types.push_back(rt);
    }
    sort_by(r.types, [](const RoadType& t) { return t.s; });

    const pugi::xml_node plan = child_named(n, "planView");
    const std::vector<pugi::xml_node> geoms = plan ? children_named(plan, "geometry") : std::vector<pugi::xml_node>{};
    if (geoms.empty()) src_.fail(plan ? plan : n, where, "road has no <planView><geometry>");
    for (size_t i = 0; i < geoms.size(); ++i) r.geometries.push_back(geometry(geoms[i], where + " geometry " + std::to_string(i)));
    if (!std::is_sorted(r.geometries.begin(), r.geometries.end(),
                        [](const Geometry& a, const Geometry& b) { return a.s < b.s; }))
      src_.warn(n, where, "planView geometries are not in s order; sorted");
    sort_by(r.geometries, [](const Geometry& g) { return g.s; });
    const Geometry& last = r.geometries.back();
    if (std::fabs(last.s + last.length - r.length) > 0.01)
      src_.warn(n, where, "road length " + std::to_string(r.length) + " differs from the plan view's end s " +
                              std::to_string(last.s + last.length));

    if (pugi::xml_node e = child_named(n, "elevationProfile"))
      r.elevation = profile(e, "elevation", where + " elevation", true);
    if (pugi::xml_node l = child_named(n, "lateralProfile"))
      r.superelevation = profile(l, "superelevation", where + " superelevation", false);
    const pugi::xml_node lanes = child_named(n, "lanes");
    if (!lanes) src_.fail(n, where, "road has no <lanes>");
    r.lane_offset = profile(lanes, "laneOffset", where + " laneOffset", true);
    const std::vector<pugi::xml_node> secs = children_named(lanes, "laneSection");
    if (secs.empty()) src_.fail(lanes, where, "road has no <laneSection>");
    for (size_t i = 0; i < secs.size(); ++i)
      r.sections.push_back(section(secs[i], where + " laneSection " + std::to_string(i)));
    sort_by(r.sections, [](const LaneSection& s) { return s.s; });
    return r;
  }

  Junction junction(const pugi::xml_node& n, size_t index) {
    Junction j;
    j.line = src_.line_of(n);
    j.id = src_.string(n, "id", "junction #" + std::to_string(index));
    j.name = src_.string_or(n, "name", "");
    const std::string where = "junction " + j.id;
    for (const pugi::xml_node& c : children_named(n, "connection")) {
      Connection con;
      con.id = src_.string_or(c, "id", "");
      con.incoming_road = src_.string_or(c, "incomingRoad", "");
      con.connecting_road = src_.string_or(c, "connectingRoad", "");
      con.contact_point = src_.string_or(c, "contactPoint", "");
      const std::string cw = where + " connection " + con.id;
      if (con.connecting_road.empty()) {
        src_.warn(c, cw, "connection without connectingRoad; skipped");
        continue;
      }
      for (const pugi::xml_node& ll : children_named(c, "laneLink"))
        con.lane_links.push_back({src_.integer(ll, "from", cw + " laneLink"), src_.integer(ll, "to", cw + " laneLink")});
      j.connections.push_back(std::move(con));
    }
    return j;
  }

 private:
  RoadLink road_link(const pugi::xml_node& n) {
    RoadLink l;
    if (!n) return l;
    l.present = true;
    l.element_type = src_.string_or(n, "elementType", "road");
    l.element_id = src_.string_or(n, "elementId", "");
    l.contact_point = src_.string_or(n, "contactPoint", "");
    return l;
  }

  void check_coordinate(const pugi::xml_node& n, const char* name, double v, const std::string& where) {
    if (std::fabs(v) > kMaxCoordinate)
      src_.fail(n, where, std::string("attribute '") + name + "' = " + std::to_string(v) + " exceeds 1e9 m");
  }

  Geometry geometry(const pugi::xml_node& n, const std::string& where) {
    Geometry g;
    g.line = src_.line_of(n);
    g.s = src_.number(n, "s", where);
    g.x = src_.number(n, "x", where);
    g.y = src_.number(n, "y", where);
    g.hdg = src_.number(n, "hdg", where);
    g.length = src_.number(n, "length", where);
    check_coordinate(n, "s", g.s, where);
    check_coordinate(n, "x", g.x, where);
    check_coordinate(n, "y", g.y, where);
    check_coordinate(n, "hdg", g.hdg, where);
    if (g.length < 0.0) src_.fail(n, where, "negative length " + std::to_string(g.length));
    if (g.length > kMaxLength) src_.fail(n, where, "length " + std::to_string(g.length) + " m exceeds 1e6 m");
    pugi::xml_node k;
    for (pugi::xml_node c = n.first_child(); c && !k; c = c.next_sibling())
      if (has_local_name(c, "line") || has_local_name(c, "arc") || has_local_name(c, "spiral") ||
          has_local_name(c, "poly3") || has_local_name(c, "paramPoly3"))
        k = c;
    if (!k) src_.fail(n, where, "geometry has no <line>, <arc>, <spiral>, <poly3> or <paramPoly3>");
    auto curvature = [&](const char* name) {
      const double v = src_.number(k, name, where);
      if (std::fabs(v) > kMaxCurvature) src_.fail(k, where, std::string("attribute '") + name + "' exceeds 1e5 1/m");
      return v;
    };
    if (has_local_name(k, "line")) {
      g.kind = GeometryKind::Line;
    } else if (has_local_name(k, "arc")) {
      g.kind = GeometryKind::Arc;
      g.curvature = curvature("curvature");
    } else if (has_local_name(k, "spiral")) {
      g.kind = GeometryKind::Spiral;
      g.curv_start = curvature("curvStart");
      g.curv_end = curvature("curvEnd");
    } else if (has_local_name(k, "poly3")) {
      g.kind = GeometryKind::Poly3;
      g.a = src_.number(k, "a", where);
      g.b = src_.number(k, "b", where);
      g.c = src_.number(k, "c", where);
      g.d = src_.number(k, "d", where);
    } else {
      g.kind = GeometryKind::ParamPoly3;
      g.au = src_.number(k, "aU", where);
      g.bu = src_.number(k, "bU", where);
      g.cu = src_.number(k, "cU", where);
      g.du = src_.number(k, "dU", where);
      g.av = src_.number(k, "aV", where);
      g.bv = src_.number(k, "bV", where);
      g.cv = src_.number(k, "cV", where);
      g.dv = src_.number(k, "dV", where);
      const std::string range = src_.string_or(k, "pRange", "arcLength");
      g.normalized = range == "normalized";
      if (!g.normalized && range != "arcLength")
        src_.warn(k, where, "unknown pRange '" + range + "'; using arcLength");
    }
    return g;
  }

  Cubic cubic(const pugi::xml_node& n, const char* s_name, const std::string& where, bool a_is_length) {
    Cubic c;
    c.s = src_.number(n, s_name, where);
    c.a = src_.number_or(n, "a", 0.0, where);
    c.b = src_.number_or(n, "b", 0.0, where);
    c.c = src_.number_or(n, "c", 0.0, where);
    c.d = src_.number_or(n, "d", 0.0, where);
    check_coordinate(n, s_name, c.s, where);
    if (a_is_length) check_coordinate(n, "a", c.a, where);
    return c;
  }

  CubicProfile profile(const pugi::xml_node& parent, const char* name, const std::string& where, bool a_is_length) {
    CubicProfile p;
    const std::vector<pugi::xml_node> recs = children_named(parent, name);
    for (size_t i = 0; i < recs.size(); ++i)
      p.records.push_back(cubic(recs[i], "s", where + " " + std::to_string(i), a_is_length));
    sort_by(p.records, [](const Cubic& c) { return c.s; });
    return p;
  }

  Lane lane(const pugi::xml_node& n, const std::string& section_where) {
    Lane l;
    l.line = src_.line_of(n);
    l.id = src_.integer(n, "id", section_where + " lane");
    const std::string where = section_where + " lane " + std::to_string(l.id);
    if (std::abs(l.id) > kMaxLaneId) src_.fail(n, where, "lane id out of range (|id| > 499)");
    l.type = src_.string_or(n, "type", "none");
    l.level = src_.boolean_or(n, "level", false, where);
    if (pugi::xml_node link = child_named(n, "link")) {
      if (pugi::xml_node p = child_named(link, "predecessor")) {
        l.has_predecessor = true;
        l.predecessor = src_.integer(p, "id", where + " predecessor");
      }
      if (pugi::xml_node s = child_named(link, "successor")) {
        l.has_successor = true;
        l.successor = src_.integer(s, "id", where + " successor");
      }
    }
    for (const pugi::xml_node& w : children_named(n, "width"))
      l.widths.push_back(cubic(w, "sOffset", where + " width", true));
    for (const pugi::xml_node& b : children_named(n, "border"))
      l.borders.push_back(cubic(b, "sOffset", where + " border", true));
    sort_by(l.widths, [](const Cubic& c) { return c.s; });
    sort_by(l.borders, [](const Cubic& c) { return c.s; });
    if (!l.widths.empty() && !l.borders.empty())
      src_.warn(n, where, "lane has both <width> and <border>; using <width>");
    for (const pugi::xml_node& m : children_named(n, "roadMark")) l.marks.push_back(road_mark(m, where + " roadMark"));
    sort_by(l.marks, [](const RoadMark& m) { return m.s_offset; });
    for (const pugi::xml_node& h : children_named(n, "height")) {
      LaneHeight lh;
      lh.s_offset = src_.number(h, "sOffset", where + " height");
      lh.inner = src_.number_or(h, "inner", 0.0, where + " height");
      lh.outer = src_.number_or(h, "outer", 0.0, where + " height");
      l.heights.push_back(lh);
    }
    sort_by(l.heights, [](const LaneHeight& h) { return h.s_offset; });
    if (pugi::xml_node sp = child_named(n, "speed")) l.speed_mps = speed_to_mps(src_, sp, where + " speed");
    return l;
  }

  RoadMark road_mark(const pugi::xml_node& n, const std::string& where) {
    RoadMark m;
    m.line = src_.line_of(n);
    m.s_offset = src_.number(n, "sOffset", where);
    check_coordinate(n, "sOffset", m.s_offset, where);
    m.type = src_.string_or(n, "type", "none");
    m.color = src_.string_or(n, "color", "standard");
    m.weight = src_.string_or(n, "weight", "standard");
    m.width = src_.number_or(n, "width", 0.0, where);
    if (pugi::xml_node t = child_named(n, "type")) {
      m.explicit_name = src_.string_or(t, "name", "");
      for (const pugi::xml_node& ln : children_named(t, "line")) {
        RoadMarkLine rl;
        const std::string lw = where + " type line";
        rl.length = src_.number_or(ln, "length", 0.0, lw);
        rl.space = src_.number_or(ln, "space", 0.0, lw);
        rl.t_offset = src_.number_or(ln, "tOffset", 0.0, lw);
        rl.s_offset = src_.number_or(ln, "sOffset", 0.0, lw);
        rl.width = src_.number_or(ln, "width", 0.0, lw);
        rl.rule = src_.string_or(ln, "rule", "");
        rl.color = src_.string_or(ln, "color", "");
        m.lines.push_back(rl);
      }
    }
    return m;
  }

  LaneSection section(const pugi::xml_node& n, const std::string& where) {
    LaneSection sec;
    sec.line = src_.line_of(n);
    sec.s = src_.number(n, "s", where);
    check_coordinate(n, "s", sec.s, where);
    sec.single_side = src_.boolean_or(n, "singleSide", false, where);
    std::vector<Lane> left, right;
    bool have_center = false;
    std::set<int> seen;
    auto take = [&](const char* side, int sign, std::vector<Lane>* out) {
      const pugi::xml_node group = child_named(n, side);
      if (!group) return;
      for (const pugi::xml_node& ln : children_named(group, "lane")) {
        Lane l = lane(ln, where);
        const bool ok = sign > 0 ? l.id > 0 : sign < 0 ? l.id < 0 : l.id == 0;
        if (!ok) src_.fail(ln, where + " lane " + std::to_string(l.id), std::string("lane id does not belong in <") + side + ">");
        if (!seen.insert(l.id).second) src_.fail(ln, where + " lane " + std::to_string(l.id), "duplicate lane id");
        if (sign == 0) {
          sec.center = std::move(l);
          have_center = true;
        } else {
          if (l.widths.empty() && l.borders.empty())
            src_.warn(ln, where + " lane " + std::to_string(l.id), "lane has no <width> or <border>; width 0");
          out->push_back(std::move(l));
        }
      }
    };
    take("left", 1, &left);
    take("center", 0, nullptr);
    take("right", -1, &right);
    if (!have_center) {
      src_.warn(n, where, "lane section has no centre lane; assuming one without marks");
      sec.center = Lane{};
    }
    std::sort(left.begin(), left.end(), [](const Lane& a, const Lane& b) { return a.id > b.id; });
    std::sort(right.begin(), right.end(), [](const Lane& a, const Lane& b) { return a.id > b.id; });
    sec.n_left = left.size();
    sec.lanes = std::move(left);
    for (Lane& l : right) sec.lanes.push_back(std::move(l));
    return sec;
  }

  const XmlSource& src_;
  Document& doc_;
};

}  // namespace

Document parse_document(const char* xml, size_t size, const std::string& file, Diagnostics* diag) {
  XmlSource src(xml, size, file, diag);
  pugi::xml_document xdoc;
  const pugi::xml_parse_result res = xdoc.load_buffer(xml, size, pugi::parse_default, pugi::encoding_auto);
  if (!res) {
    const int line = src.line_of_offset(res.offset);
    throw InputError(file, "line " + std::to_string(line), std::string("XML parse error: ") + res.description());
  }
  const pugi::xml_node root = xdoc.document_element();
  if (!has_local_name(root, "OpenDRIVE"))
    src.fail(root, "", std::string("root element is <") + root.name() + ">, not <OpenDRIVE>");

  Document doc;
  doc.file = file;
  Parser p(src, doc);
  if (pugi::xml_node h = child_named(root, "header")) p.header(h);
  else src.warn(root, "", "no <header>; assuming OpenDRIVE 1.4");
  std::set<std::string> road_ids;
  size_t index = 0;
  for (const pugi::xml_node& r : children_named(root, "road")) {
    doc.roads.push_back(p.road(r, index++));
    if (!road_ids.insert(doc.roads.back().id).second)
      src.warn(r, "road " + doc.roads.back().id, "duplicate road id");
  }
  index = 0;
  for (const pugi::xml_node& j : children_named(root, "junction")) doc.junctions.push_back(p.junction(j, index++));
  return doc;
}

}  // namespace icube::scene::odr
