// The project's scene format (docs/scene-format.md): writing a Scene as
// versioned JSON and reading it back strictly, with JSON paths in errors.
//
// Doubles are printed by nlohmann's serializer, whose shortest round-trip
// formatting (Grisu2 with a round-trip guarantee, ".0" kept on integral
// values, "-0.0" kept) reads back bit-exactly. JSON has no NaN/Inf, so the
// writer refuses them with the path of the value; the reader rejects
// out-of-range numbers ("1e400") and anything of the wrong type.
#include "scene/scene_json.h"

#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string_view>

namespace icube::scene {

namespace {

using Json = nlohmann::ordered_json;

constexpr const char* kFormatName = "icube-scene";

// ---- paths -----------------------------------------------------------------------
// A JSON value and where it is, as a chain up to the document root. Paths are
// only formatted when something goes wrong.
struct At {
  const Json& j;
  const At* parent = nullptr;
  std::string_view key;  // member name; empty for an array element or the root
  size_t index = 0;      // array index when key is empty and parent is set
};

std::string format_path(const At& at) {
  std::vector<const At*> chain;
  for (const At* a = &at; a && a->parent; a = a->parent) chain.push_back(a);
  std::string s;
  for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
    const At& a = **it;
    if (!a.key.empty()) {
      if (!s.empty()) s += '.';
      s += a.key;
    } else {
      s += '[' + std::to_string(a.index) + ']';
    }
  }
  return s;
}

// Writer-side path: segments pushed while walking the document.
struct WalkPath {
  struct Segment {
    std::string_view key;
    size_t index;
  };
  std::vector<Segment> segments;
  std::string str() const {
    std::string s;
    for (const Segment& g : segments) {
      if (!g.key.empty()) {
        if (!s.empty()) s += '.';
        s += g.key;
      } else {
        s += '[' + std::to_string(g.index) + ']';
      }
    }
    return s;
  }
};

// ---- writing ---------------------------------------------------------------------

Json vec_json(const glm::dvec3& v) { return Json::array({v.x, v.y, v.z}); }

Json points_json(const std::vector<glm::dvec3>& pts) {
  Json a = Json::array();
  for (const glm::dvec3& p : pts) a.push_back(vec_json(p));
  return a;
}

Json ids_json(const std::vector<int64_t>& ids) {
  Json a = Json::array();
  for (int64_t id : ids) a.push_back(id);
  return a;
}

// 4×4 as 4 rows of 4 (row-major); glm is column-major, m[col][row].
Json mat4_json(const glm::dmat4& m) {
  Json rows = Json::array();
  for (int r = 0; r < 4; ++r) rows.push_back(Json::array({m[0][r], m[1][r], m[2][r], m[3][r]}));
  return rows;
}

Json map_json(const Map& map) {
  Json m = Json::object();
  m["geo_reference"] = map.geo_reference;
  Json& edges = m["road_edges"] = Json::array();
  for (const RoadEdge& e : map.road_edges)
    edges.push_back({{"id", e.id}, {"type", road_edge_type_name(e.type)}, {"points", points_json(e.points)}});
  Json& lines = m["road_lines"] = Json::array();
  for (const RoadLine& l : map.road_lines)
    lines.push_back({{"id", l.id},
                     {"type", road_line_type_name(l.type)},
                     {"source_type", l.source_type},
                     {"points", points_json(l.points)}});
  Json& lanes = m["lanes"] = Json::array();
  for (const Lane& l : map.lanes)
    lanes.push_back({{"id", l.id},
                     {"type", lane_type_name(l.type)},
                     {"speed_limit_mph", l.speed_limit_mph},
                     {"interpolating", l.interpolating},
                     {"entry_lanes", ids_json(l.entry_lanes)},
                     {"exit_lanes", ids_json(l.exit_lanes)},
                     {"left_neighbors", ids_json(l.left_neighbors)},
                     {"right_neighbors", ids_json(l.right_neighbors)},
                     {"points", points_json(l.points)}});
  auto polygons = [](const std::vector<Polygon>& ps) {
    Json a = Json::array();
    for (const Polygon& p : ps) a.push_back({{"id", p.id}, {"points", points_json(p.points)}});
    return a;
  };
  m["crosswalks"] = polygons(map.crosswalks);
  m["driveways"] = polygons(map.driveways);
  m["speed_bumps"] = polygons(map.speed_bumps);
  Json& stops = m["stop_signs"] = Json::array();
  for (const StopSign& s : map.stop_signs)
    stops.push_back({{"id", s.id}, {"position", vec_json(s.position)}, {"lanes", ids_json(s.lanes)}});
  return m;
}

Json track_json(const Track& t) {
  Json states = Json::array();
  for (const BoxState& s : t.states)
    states.push_back({{"center", vec_json(s.center)},
                      {"lwh", Json::array({s.length, s.width, s.height})},
                      {"heading", s.heading},
                      {"pitch", s.pitch},
                      {"roll", s.roll},
                      {"velocity", Json::array({s.velocity.x, s.velocity.y})},
                      {"valid", s.valid}});
  return {{"id", t.id},
          {"type", object_type_name(t.type)},
          {"dynamic", t.dynamic},
          {"instance_id", t.instance_id},
          {"states", std::move(states)}};
}

Json scene_document(const Scene& s) {
  Json d = Json::object();
  d["format"] = kFormatName;
  d["version"] = kSceneJsonVersion;
  d["provenance"] = {{"source_file", s.provenance.source_file},
                     {"source_format", s.provenance.source_format},
                     {"scenario_id", s.provenance.scenario_id},
                     {"source_version", s.provenance.source_version}};
  d["prompt"] = s.prompt;
  d["timestamps"] = s.timestamps;
  d["current_time_index"] = s.current_time_index;
  d["sdc_track_index"] = s.sdc_track_index;
  d["missing"] = s.missing;
  Json& cams = d["cameras"] = Json::array();
  for (const Camera& c : s.cameras)
    cams.push_back({{"name", c.name},
                    {"fx", c.fx},
                    {"fy", c.fy},
                    {"cx", c.cx},
                    {"cy", c.cy},
                    {"width", c.width},
                    {"height", c.height},
                    {"camera_to_ego", mat4_json(c.camera_to_ego)}});
  Json& ego = d["ego"] = Json::array();
  for (const EgoPose& p : s.ego) ego.push_back({{"ego_to_world", mat4_json(p.ego_to_world)}, {"valid", p.valid}});
  d["map"] = map_json(s.map);
  Json& tracks = d["tracks"] = Json::array();
  for (const Track& t : s.tracks) tracks.push_back(track_json(t));
  return d;
}

// Position of the first byte that is not well-formed UTF-8, or npos.
size_t invalid_utf8_at(std::string_view s) {
  size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    size_t n = 0;
    uint32_t cp = 0;
    if (c < 0x80) {
      ++i;
      continue;
    } else if ((c & 0xE0) == 0xC0) {
      n = 1, cp = c & 0x1F;
    } else if ((c & 0xF0) == 0xE0) {
      n = 2, cp = c & 0x0F;
    } else if ((c & 0xF8) == 0xF0) {
      n = 3, cp = c & 0x07;
    } else {
      return i;
    }
    for (size_t k = 1; k <= n; ++k) {
      if (i + k >= s.size()) return i;
      const auto cc = static_cast<unsigned char>(s[i + k]);
      if ((cc & 0xC0) != 0x80) return i;
      cp = (cp << 6) | (cc & 0x3F);
    }
    static constexpr uint32_t kMin[4] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMin[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return i;
    i += n + 1;
  }
  return std::string_view::npos;
}

// JSON cannot hold NaN/Inf (nlohmann would print null) or invalid UTF-8:
// refuse them, naming the value.
void check_writable(const Json& j, WalkPath& path) {
  if (j.is_number_float() && !std::isfinite(j.get<double>())) {
    const double v = j.get<double>();
    throw std::runtime_error("scene_to_json: " + path.str() + " is " +
                             (std::isnan(v) ? "NaN" : v > 0 ? "+infinity" : "-infinity") +
                             "; the scene format stores finite numbers only");
  }
  if (j.is_string()) {
    const std::string& s = j.get_ref<const std::string&>();
    const size_t bad = invalid_utf8_at(s);
    if (bad != std::string_view::npos)
      throw std::runtime_error("scene_to_json: " + path.str() + ": string is not valid UTF-8 (byte " +
                               std::to_string(bad) + ")");
  } else if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i) {
      path.segments.push_back({{}, i});
      check_writable(j[i], path);
      path.segments.pop_back();
    }
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      path.segments.push_back({it.key(), 0});
      check_writable(it.value(), path);
      path.segments.pop_back();
    }
  }
}

bool is_scalar_array(const Json& j) {
  return j.is_array() && std::all_of(j.begin(), j.end(), [](const Json& e) { return e.is_primitive(); });
}

// Scalars, arrays of scalars, and objects of those print on one line.
bool prints_inline(const Json& j) {
  if (j.is_primitive() || is_scalar_array(j)) return true;
  if (!j.is_object()) return false;
  return std::all_of(j.begin(), j.end(), [](const Json& e) { return e.is_primitive() || is_scalar_array(e); });
}

void print(std::string& out, const Json& j, int indent) {
  if (prints_inline(j) || j.empty()) {
    out += j.dump();
    return;
  }
  const std::string pad(size_t(indent + 2), ' ');
  out += j.is_array() ? "[\n" : "{\n";
  bool first = true;
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!first) out += ",\n";
    first = false;
    out += pad;
    if (j.is_object()) {
      out += Json(it.key()).dump();
      out += ": ";
    }
    print(out, it.value(), indent + 2);
  }
  out += '\n';
  out += std::string(size_t(indent), ' ');
  out += j.is_array() ? ']' : '}';
}

// ---- reading ---------------------------------------------------------------------

const char* type_name(const Json& j) {
  if (j.is_number_integer()) return "an integer";
  if (j.is_number_float()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_boolean()) return "a boolean";
  if (j.is_null()) return "null";
  if (j.is_array()) return "an array";
  if (j.is_object()) return "an object";
  return "an unknown value";
}

class Reader {
 public:
  Reader(const std::string& file, Diagnostics* diag) : file_(file), diag_(diag) {}

  [[noreturn]] void fail(const At& at, const std::string& what) const {
    throw InputError(file_, format_path(at), what);
  }
  void warn(const At& at, const std::string& what) const {
    if (diag_) diag_->warn(file_, format_path(at), what);
  }
  [[noreturn]] void wrong_type(const At& at, const char* expected) const {
    fail(at, std::string("expected ") + expected + ", got " + type_name(at.j));
  }

  // Checks that `at` is an object and warns about keys not in `known`.
  void object(const At& at, std::initializer_list<std::string_view> known) const {
    if (!at.j.is_object()) wrong_type(at, "an object");
    for (auto it = at.j.begin(); it != at.j.end(); ++it) {
      if (std::find(known.begin(), known.end(), std::string_view(it.key())) == known.end())
        warn(at, "unknown key '" + it.key() + "' ignored");
    }
  }
  const Json* find(const At& obj, std::string_view key) const {
    auto it = obj.j.find(std::string(key));
    return it == obj.j.end() ? nullptr : &*it;
  }
  const Json& require(const At& obj, std::string_view key) const {
    const Json* v = find(obj, key);
    if (!v) fail(obj, "missing required key '" + std::string(key) + "'");
    return *v;
  }

  double number(const At& at) const {
    if (!at.j.is_number()) wrong_type(at, "a number");
    const double v = at.j.get<double>();
    if (!std::isfinite(v)) fail(at, "number is not finite");
    return v;
  }
  int64_t integer(const At& at, int64_t lo = std::numeric_limits<int64_t>::min(),
                  int64_t hi = std::numeric_limits<int64_t>::max()) const {
    if (!at.j.is_number_integer()) wrong_type(at, "an integer");
    if (at.j.is_number_unsigned() && at.j.get<uint64_t>() > uint64_t(std::numeric_limits<int64_t>::max()))
      fail(at, "integer " + at.j.dump() + " is out of range");
    const int64_t v = at.j.get<int64_t>();
    if (v < lo || v > hi)
      fail(at, "integer " + std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) +
                   "]");
    return v;
  }
  bool boolean(const At& at) const {
    if (!at.j.is_boolean()) wrong_type(at, "a boolean (true/false)");
    return at.j.get<bool>();
  }
  std::string string(const At& at) const {
    if (!at.j.is_string()) wrong_type(at, "a string");
    return at.j.get<std::string>();
  }
  const Json& array(const At& at, size_t exact_size = SIZE_MAX) const {
    if (!at.j.is_array()) wrong_type(at, "an array");
    if (exact_size != SIZE_MAX && at.j.size() != exact_size)
      fail(at, "expected " + std::to_string(exact_size) + " elements, got " + std::to_string(at.j.size()));
    return at.j;
  }

  template <class F>
  void each(const At& arr, F&& f) const {
    array(arr);
    for (size_t i = 0; i < arr.j.size(); ++i) f(At{arr.j[i], &arr, {}, i});
  }

  // Optional member: calls f(At) when present.
  template <class F>
  void opt(const At& obj, std::string_view key, F&& f) const {
    if (const Json* v = find(obj, key)) f(At{*v, &obj, key, 0});
  }
  template <class F>
  void req(const At& obj, std::string_view key, F&& f) const {
    f(At{require(obj, key), &obj, key, 0});
  }

  glm::dvec3 vec3(const At& at) const {
    array(at, 3);
    return {number({at.j[0], &at, {}, 0}), number({at.j[1], &at, {}, 1}), number({at.j[2], &at, {}, 2})};
  }
  std::vector<glm::dvec3> points(const At& at) const {
    std::vector<glm::dvec3> pts;
    pts.reserve(array(at).size());
    each(at, [&](const At& p) { pts.push_back(vec3(p)); });
    return pts;
  }
  std::vector<int64_t> ids(const At& at) const {
    std::vector<int64_t> v;
    v.reserve(array(at).size());
    each(at, [&](const At& e) { v.push_back(integer(e)); });
    return v;
  }
  glm::dmat4 mat4(const At& at) const {
    array(at, 4);
    glm::dmat4 m(0.0);
    each(at, [&](const At& row) {
      array(row, 4);
      for (size_t c = 0; c < 4; ++c) m[int(c)][int(row.index)] = number({row.j[c], &row, {}, c});
    });
    if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0)
      fail({at.j[3], &at, {}, 3}, "the last row of a rigid transform must be [0, 0, 0, 1]");
    return m;
  }

  // Enums are stored by name; `name_of` maps each value 0..count-1 to its name.
  template <class E>
  E enumeration(const At& at, const char* (*name_of)(E), int count) const {
    const std::string s = string(at);
    std::string all;
    for (int v = 0; v < count; ++v) {
      const char* n = name_of(static_cast<E>(v));
      if (s == n) return static_cast<E>(v);
      all += (v ? ", " : "") + std::string(n);
    }
    fail(at, "unknown value '" + s + "' (expected one of: " + all + ")");
  }

 private:
  const std::string& file_;
  Diagnostics* diag_;
};

Provenance read_provenance(const Reader& r, const At& at) {
  r.object(at, {"source_file", "source_format", "scenario_id", "source_version"});
  Provenance p;
  r.opt(at, "source_file", [&](const At& v) { p.source_file = r.string(v); });
  r.opt(at, "source_format", [&](const At& v) { p.source_format = r.string(v); });
  r.opt(at, "scenario_id", [&](const At& v) { p.scenario_id = r.string(v); });
  r.opt(at, "source_version", [&](const At& v) { p.source_version = r.string(v); });
  return p;
}

std::vector<Polygon> read_polygons(const Reader& r, const At& at) {
  std::vector<Polygon> out;
  r.each(at, [&](const At& e) {
    r.object(e, {"id", "points"});
    Polygon p;
    r.req(e, "id", [&](const At& v) { p.id = r.integer(v); });
    r.req(e, "points", [&](const At& v) { p.points = r.points(v); });
    out.push_back(std::move(p));
  });
  return out;
}

Map read_map(const Reader& r, const At& at) {
  r.object(at, {"geo_reference", "road_edges", "road_lines", "lanes", "crosswalks", "driveways", "speed_bumps",
                "stop_signs"});
  Map m;
  r.opt(at, "geo_reference", [&](const At& v) { m.geo_reference = r.string(v); });
  r.opt(at, "road_edges", [&](const At& arr) {
    r.each(arr, [&](const At& e) {
      r.object(e, {"id", "type", "points"});
      RoadEdge x;
      r.req(e, "id", [&](const At& v) { x.id = r.integer(v); });
      r.opt(e, "type", [&](const At& v) { x.type = r.enumeration(v, road_edge_type_name, 4); });
      r.req(e, "points", [&](const At& v) { x.points = r.points(v); });
      m.road_edges.push_back(std::move(x));
    });
  });
  r.opt(at, "road_lines", [&](const At& arr) {
    r.each(arr, [&](const At& e) {
      r.object(e, {"id", "type", "source_type", "points"});
      RoadLine x;
      r.req(e, "id", [&](const At& v) { x.id = r.integer(v); });
      r.opt(e, "type", [&](const At& v) { x.type = r.enumeration(v, road_line_type_name, 9); });
      r.opt(e, "source_type", [&](const At& v) { x.source_type = r.string(v); });
      r.req(e, "points", [&](const At& v) { x.points = r.points(v); });
      m.road_lines.push_back(std::move(x));
    });
  });
  r.opt(at, "lanes", [&](const At& arr) {
    r.each(arr, [&](const At& e) {
      r.object(e, {"id", "type", "speed_limit_mph", "interpolating", "entry_lanes", "exit_lanes", "left_neighbors",
                   "right_neighbors", "points"});
      Lane x;
      r.req(e, "id", [&](const At& v) { x.id = r.integer(v); });
      r.opt(e, "type", [&](const At& v) { x.type = r.enumeration(v, lane_type_name, 4); });
      r.opt(e, "speed_limit_mph", [&](const At& v) { x.speed_limit_mph = r.number(v); });
      r.opt(e, "interpolating", [&](const At& v) { x.interpolating = r.boolean(v); });
      r.opt(e, "entry_lanes", [&](const At& v) { x.entry_lanes = r.ids(v); });
      r.opt(e, "exit_lanes", [&](const At& v) { x.exit_lanes = r.ids(v); });
      r.opt(e, "left_neighbors", [&](const At& v) { x.left_neighbors = r.ids(v); });
      r.opt(e, "right_neighbors", [&](const At& v) { x.right_neighbors = r.ids(v); });
      r.req(e, "points", [&](const At& v) { x.points = r.points(v); });
      m.lanes.push_back(std::move(x));
    });
  });
  r.opt(at, "crosswalks", [&](const At& v) { m.crosswalks = read_polygons(r, v); });
  r.opt(at, "driveways", [&](const At& v) { m.driveways = read_polygons(r, v); });
  r.opt(at, "speed_bumps", [&](const At& v) { m.speed_bumps = read_polygons(r, v); });
  r.opt(at, "stop_signs", [&](const At& arr) {
    r.each(arr, [&](const At& e) {
      r.object(e, {"id", "position", "lanes"});
      StopSign x;
      r.req(e, "id", [&](const At& v) { x.id = r.integer(v); });
      r.req(e, "position", [&](const At& v) { x.position = r.vec3(v); });
      r.opt(e, "lanes", [&](const At& v) { x.lanes = r.ids(v); });
      m.stop_signs.push_back(std::move(x));
    });
  });
  return m;
}

BoxState read_state(const Reader& r, const At& at) {
  r.object(at, {"center", "lwh", "heading", "pitch", "roll", "velocity", "valid"});
  BoxState s;
  r.req(at, "center", [&](const At& v) { s.center = r.vec3(v); });
  r.req(at, "lwh", [&](const At& v) {
    const glm::dvec3 lwh = r.vec3(v);
    s.length = lwh.x, s.width = lwh.y, s.height = lwh.z;
  });
  r.req(at, "heading", [&](const At& v) { s.heading = r.number(v); });
  r.opt(at, "pitch", [&](const At& v) { s.pitch = r.number(v); });
  r.opt(at, "roll", [&](const At& v) { s.roll = r.number(v); });
  r.opt(at, "velocity", [&](const At& v) {
    r.array(v, 2);
    s.velocity = {r.number({v.j[0], &v, {}, 0}), r.number({v.j[1], &v, {}, 1})};
  });
  r.req(at, "valid", [&](const At& v) { s.valid = r.boolean(v); });
  return s;
}

Track read_track(const Reader& r, const At& at) {
  r.object(at, {"id", "type", "dynamic", "instance_id", "states"});
  Track t;
  r.req(at, "id", [&](const At& v) { t.id = r.integer(v); });
  r.opt(at, "type", [&](const At& v) { t.type = r.enumeration(v, object_type_name, 6); });
  r.opt(at, "dynamic", [&](const At& v) { t.dynamic = r.boolean(v); });
  r.opt(at, "instance_id", [&](const At& v) { t.instance_id = uint32_t(r.integer(v, 0, UINT32_MAX)); });
  r.req(at, "states", [&](const At& arr) {
    t.states.reserve(r.array(arr).size());
    r.each(arr, [&](const At& e) { t.states.push_back(read_state(r, e)); });
  });
  return t;
}

Camera read_camera(const Reader& r, const At& at) {
  r.object(at, {"name", "fx", "fy", "cx", "cy", "width", "height", "camera_to_ego"});
  Camera c;
  r.opt(at, "name", [&](const At& v) { c.name = r.string(v); });
  r.req(at, "fx", [&](const At& v) { c.fx = r.number(v); });
  r.req(at, "fy", [&](const At& v) { c.fy = r.number(v); });
  r.req(at, "cx", [&](const At& v) { c.cx = r.number(v); });
  r.req(at, "cy", [&](const At& v) { c.cy = r.number(v); });
  r.req(at, "width", [&](const At& v) { c.width = uint32_t(r.integer(v, 0, UINT32_MAX)); });
  r.req(at, "height", [&](const At& v) { c.height = uint32_t(r.integer(v, 0, UINT32_MAX)); });
  r.opt(at, "camera_to_ego", [&](const At& v) { c.camera_to_ego = r.mat4(v); });
  return c;
}

// Invariants of the scene model that the rest of the engine relies on.
void check_consistency(const Reader& r, const At& root, const Scene& s) {
  const Json* ts = r.find(root, "timestamps");
  for (size_t i = 1; i < s.timestamps.size(); ++i) {
    if (!(s.timestamps[i] > s.timestamps[i - 1])) {
      const At arr{*ts, &root, "timestamps", 0};
      r.fail(At{(*ts)[i], &arr, {}, i}, "timestamps must increase (" + (*ts)[i].dump() + " after " +
                                            (*ts)[i - 1].dump() + ")");
    }
  }
  if (const Json* tracks = r.find(root, "tracks")) {
    const At arr{*tracks, &root, "tracks", 0};
    for (size_t i = 0; i < s.tracks.size(); ++i) {
      if (s.tracks[i].states.size() != s.timestamps.size()) {
        const At track{(*tracks)[i], &arr, {}, i};
        r.fail(At{r.require(track, "states"), &track, "states", 0},
               "has " + std::to_string(s.tracks[i].states.size()) + " states but the scene has " +
                   std::to_string(s.timestamps.size()) + " timestamps (one state per timestamp)");
      }
    }
  }
  if (!s.ego.empty() && s.ego.size() != s.timestamps.size())
    r.fail(At{r.require(root, "ego"), &root, "ego", 0},
           "has " + std::to_string(s.ego.size()) + " poses but the scene has " + std::to_string(s.timestamps.size()) +
               " timestamps (one pose per timestamp, or none)");
  if (const Json* v = r.find(root, "sdc_track_index"); v && (s.sdc_track_index < -1 ||
                                                            s.sdc_track_index >= int64_t(s.tracks.size())))
    r.fail(At{*v, &root, "sdc_track_index", 0}, std::to_string(s.sdc_track_index) + " is not -1 or a track index (" +
                                                    std::to_string(s.tracks.size()) + " tracks)");
  if (const Json* v = r.find(root, "current_time_index");
      v && (s.current_time_index < 0 ||
            size_t(s.current_time_index) >= std::max<size_t>(s.timestamps.size(), 1)))
    r.fail(At{*v, &root, "current_time_index", 0},
           std::to_string(s.current_time_index) + " is not a timestamp index (" + std::to_string(s.timestamps.size()) +
               " timestamps)");
}

Scene read_document(const Reader& r, const At& root) {
  if (!root.j.is_object()) r.fail(root, std::string("expected a JSON object at the top level, got ") + type_name(root.j));
  const Json* format = r.find(root, "format");
  if (!format) r.fail(root, "missing required key 'format' (not an icube scene file?)");
  const At format_at{*format, &root, "format", 0};
  if (r.string(format_at) != kFormatName)
    r.fail(format_at, "format is '" + format->get<std::string>() + "', expected '" + kFormatName + "'");
  const At version_at{r.require(root, "version"), &root, "version", 0};
  const int64_t version = r.integer(version_at);
  if (version > kSceneJsonVersion)
    r.fail(version_at, "version " + std::to_string(version) + " is newer than this build reads (version " +
                           std::to_string(kSceneJsonVersion) + "); update icube");
  if (version < 1) r.fail(version_at, "unsupported version " + std::to_string(version));

  r.object(root, {"format", "version", "provenance", "prompt", "timestamps", "current_time_index", "sdc_track_index",
                  "missing", "cameras", "ego", "map", "tracks"});
  Scene s;
  r.opt(root, "provenance", [&](const At& v) { s.provenance = read_provenance(r, v); });
  r.opt(root, "prompt", [&](const At& v) { s.prompt = r.string(v); });
  r.opt(root, "timestamps", [&](const At& arr) {
    s.timestamps.reserve(r.array(arr).size());
    r.each(arr, [&](const At& e) { s.timestamps.push_back(r.number(e)); });
  });
  r.opt(root, "current_time_index",
        [&](const At& v) { s.current_time_index = int(r.integer(v, INT32_MIN, INT32_MAX)); });
  r.opt(root, "sdc_track_index", [&](const At& v) { s.sdc_track_index = int(r.integer(v, INT32_MIN, INT32_MAX)); });
  r.opt(root, "missing", [&](const At& arr) { r.each(arr, [&](const At& e) { s.missing.push_back(r.string(e)); }); });
  r.opt(root, "cameras", [&](const At& arr) { r.each(arr, [&](const At& e) { s.cameras.push_back(read_camera(r, e)); }); });
  r.opt(root, "ego", [&](const At& arr) {
    r.each(arr, [&](const At& e) {
      r.object(e, {"ego_to_world", "valid"});
      EgoPose p;
      r.req(e, "ego_to_world", [&](const At& v) { p.ego_to_world = r.mat4(v); });
      r.opt(e, "valid", [&](const At& v) { p.valid = r.boolean(v); });
      s.ego.push_back(p);
    });
  });
  r.opt(root, "map", [&](const At& v) { s.map = read_map(r, v); });
  r.opt(root, "tracks", [&](const At& arr) {
    s.tracks.reserve(r.array(arr).size());
    r.each(arr, [&](const At& e) { s.tracks.push_back(read_track(r, e)); });
  });
  check_consistency(r, root, s);
  return s;
}

// Line and column (1-based) of byte offset `pos` in `text`.
std::string line_column(const std::string& text, size_t pos) {
  pos = std::min(pos, text.size());
  size_t line = 1, line_start = 0;
  for (size_t i = 0; i < pos; ++i)
    if (text[i] == '\n') ++line, line_start = i + 1;
  return "line " + std::to_string(line) + ", column " + std::to_string(pos - line_start + 1);
}

// nlohmann messages start with "[json.exception.parse_error.101] parse error at line 1, column 2: ".
std::string strip_nlohmann_prefix(std::string m) {
  if (m.rfind("[json.exception.", 0) == 0) {
    const size_t close = m.find("] ");
    if (close != std::string::npos) m.erase(0, close + 2);
  }
  if (m.rfind("parse error", 0) == 0) {
    const size_t colon = m.find(": ");
    if (colon != std::string::npos) m.erase(0, colon + 2);
  }
  return m;
}

}  // namespace

std::string scene_to_json(const Scene& scene) {
  const Json doc = scene_document(scene);
  WalkPath path;
  check_writable(doc, path);
  std::string out;
  print(out, doc, 0);
  out += '\n';
  return out;
}

Scene scene_from_json(const std::string& text, const std::string& file, Diagnostics* diag) {
  Json doc;
  try {
    doc = Json::parse(text);
  } catch (const Json::parse_error& e) {
    // e.byte is 1-based: the last byte read.
    throw InputError(file, line_column(text, e.byte ? e.byte - 1 : 0), strip_nlohmann_prefix(e.what()));
  } catch (const Json::exception& e) {
    // Number overflow ("number overflow parsing '1e400'") comes without a
    // position: point at the first occurrence of the token.
    const std::string what = strip_nlohmann_prefix(e.what());
    std::string where;
    const size_t open = what.find('\''), close = what.rfind('\'');
    if (open != std::string::npos && close > open) {
      const size_t at = text.find(what.substr(open + 1, close - open - 1));
      if (at != std::string::npos) where = line_column(text, at);
    }
    throw InputError(file, where, what);
  }
  const Reader reader(file, diag);
  return read_document(reader, At{doc, nullptr, {}, 0});
}

void write_scene_json(const Scene& scene, const std::string& path) { write_file_atomic(path, scene_to_json(scene)); }

Scene read_scene_json(const std::string& path, Diagnostics* diag) { return scene_from_json(read_file(path), path, diag); }

}  // namespace icube::scene
