// The icube scene JSON format (engine/scene/scene_json.h, docs/scene-format.md):
// bit-exact round trips (randomized scenes, awkward doubles, the real Waymo
// scenario and OpenDRIVE maps), exact error messages with file and JSON path
// for malformed input, defaults for optional fields, warnings for unknown
// keys, and the atomic writer.
#include "gpu_test_context.h"
#include "scene/atomic_file.h"
#include "scene/opendrive_reader.h"
#include "scene/scene_json.h"
#include "scene/waymo_reader.h"

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <unistd.h>

using namespace icube::scene;
using Json = nlohmann::ordered_json;

namespace {

// ---- comparing scenes field by field (doubles by bit pattern) --------------------

struct SceneDiff {
  std::vector<std::string> diffs;
  void note(const std::string& path, const std::string& what) {
    if (diffs.size() < 10) diffs.push_back(path + ": " + what);
  }
  static uint64_t bits(double v) {
    uint64_t b;
    std::memcpy(&b, &v, 8);
    return b;
  }
  void num(const std::string& p, double a, double b) {
    if (bits(a) != bits(b)) note(p, std::to_string(a) + " vs " + std::to_string(b) + " (bits differ)");
  }
  template <class T>
  void eq(const std::string& p, const T& a, const T& b) {
    if (!(a == b)) note(p, "differs");
  }
  void v3(const std::string& p, const glm::dvec3& a, const glm::dvec3& b) {
    for (int i = 0; i < 3; ++i) num(p + "[" + std::to_string(i) + "]", a[i], b[i]);
  }
  void pts(const std::string& p, const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b) {
    if (a.size() != b.size()) return note(p, "size " + std::to_string(a.size()) + " vs " + std::to_string(b.size()));
    for (size_t i = 0; i < a.size(); ++i) v3(p + "[" + std::to_string(i) + "]", a[i], b[i]);
  }
  void m4(const std::string& p, const glm::dmat4& a, const glm::dmat4& b) {
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) num(p + "[" + std::to_string(r) + "][" + std::to_string(c) + "]", a[c][r], b[c][r]);
  }
  template <class T, class F>
  void list(const std::string& p, const std::vector<T>& a, const std::vector<T>& b, F&& f) {
    if (a.size() != b.size()) return note(p, "size " + std::to_string(a.size()) + " vs " + std::to_string(b.size()));
    for (size_t i = 0; i < a.size(); ++i) f(p + "[" + std::to_string(i) + "]", a[i], b[i]);
  }

  void scene(const Scene& a, const Scene& b) {
    eq("provenance.source_file", a.provenance.source_file, b.provenance.source_file);
    eq("provenance.source_format", a.provenance.source_format, b.provenance.source_format);
    eq("provenance.scenario_id", a.provenance.scenario_id, b.provenance.scenario_id);
    eq("provenance.source_version", a.provenance.source_version, b.provenance.source_version);
    eq("prompt", a.prompt, b.prompt);
    list("timestamps", a.timestamps, b.timestamps, [&](auto p, double x, double y) { num(p, x, y); });
    eq("sdc_track_index", a.sdc_track_index, b.sdc_track_index);
    eq("current_time_index", a.current_time_index, b.current_time_index);
    eq("missing", a.missing, b.missing);
    const Map &ma = a.map, &mb = b.map;
    eq("map.geo_reference", ma.geo_reference, mb.geo_reference);
    list("map.road_edges", ma.road_edges, mb.road_edges, [&](auto p, const RoadEdge& x, const RoadEdge& y) {
      eq(p + ".id", x.id, y.id);
      eq(p + ".type", x.type, y.type);
      pts(p + ".points", x.points, y.points);
    });
    list("map.road_lines", ma.road_lines, mb.road_lines, [&](auto p, const RoadLine& x, const RoadLine& y) {
      eq(p + ".id", x.id, y.id);
      eq(p + ".type", x.type, y.type);
      eq(p + ".source_type", x.source_type, y.source_type);
      pts(p + ".points", x.points, y.points);
    });
    list("map.lanes", ma.lanes, mb.lanes, [&](auto p, const Lane& x, const Lane& y) {
      eq(p + ".id", x.id, y.id);
      eq(p + ".type", x.type, y.type);
      num(p + ".speed_limit_mph", x.speed_limit_mph, y.speed_limit_mph);
      eq(p + ".interpolating", x.interpolating, y.interpolating);
      eq(p + ".entry_lanes", x.entry_lanes, y.entry_lanes);
      eq(p + ".exit_lanes", x.exit_lanes, y.exit_lanes);
      eq(p + ".left_neighbors", x.left_neighbors, y.left_neighbors);
      eq(p + ".right_neighbors", x.right_neighbors, y.right_neighbors);
      pts(p + ".points", x.points, y.points);
    });
    auto poly = [&](auto p, const Polygon& x, const Polygon& y) {
      eq(p + ".id", x.id, y.id);
      pts(p + ".points", x.points, y.points);
    };
    list("map.crosswalks", ma.crosswalks, mb.crosswalks, poly);
    list("map.driveways", ma.driveways, mb.driveways, poly);
    list("map.speed_bumps", ma.speed_bumps, mb.speed_bumps, poly);
    list("map.stop_signs", ma.stop_signs, mb.stop_signs, [&](auto p, const StopSign& x, const StopSign& y) {
      eq(p + ".id", x.id, y.id);
      v3(p + ".position", x.position, y.position);
      eq(p + ".lanes", x.lanes, y.lanes);
    });
    list("tracks", a.tracks, b.tracks, [&](auto p, const Track& x, const Track& y) {
      eq(p + ".id", x.id, y.id);
      eq(p + ".type", x.type, y.type);
      eq(p + ".dynamic", x.dynamic, y.dynamic);
      eq(p + ".instance_id", x.instance_id, y.instance_id);
      list(p + ".states", x.states, y.states, [&](auto q, const BoxState& s, const BoxState& t) {
        v3(q + ".center", s.center, t.center);
        num(q + ".length", s.length, t.length);
        num(q + ".width", s.width, t.width);
        num(q + ".height", s.height, t.height);
        num(q + ".heading", s.heading, t.heading);
        num(q + ".pitch", s.pitch, t.pitch);
        num(q + ".roll", s.roll, t.roll);
        num(q + ".velocity[0]", s.velocity.x, t.velocity.x);
        num(q + ".velocity[1]", s.velocity.y, t.velocity.y);
        eq(q + ".valid", s.valid, t.valid);
      });
    });
    list("ego", a.ego, b.ego, [&](auto p, const EgoPose& x, const EgoPose& y) {
      m4(p + ".ego_to_world", x.ego_to_world, y.ego_to_world);
      eq(p + ".valid", x.valid, y.valid);
    });
    list("cameras", a.cameras, b.cameras, [&](auto p, const Camera& x, const Camera& y) {
      eq(p + ".name", x.name, y.name);
      num(p + ".fx", x.fx, y.fx);
      num(p + ".fy", x.fy, y.fy);
      num(p + ".cx", x.cx, y.cx);
      num(p + ".cy", x.cy, y.cy);
      eq(p + ".width", x.width, y.width);
      eq(p + ".height", x.height, y.height);
      m4(p + ".camera_to_ego", x.camera_to_ego, y.camera_to_ego);
    });
  }
};

void check_same(const Scene& a, const Scene& b) {
  SceneDiff d;
  d.scene(a, b);
  for (const std::string& s : d.diffs) MESSAGE("differs: ", s);
  CHECK(d.diffs.empty());
}

// Round trip through text; also checks that writing is a fixpoint.
void check_round_trip(const Scene& scene) {
  const std::string text = scene_to_json(scene);
  const Scene back = scene_from_json(text, "round-trip.json");
  check_same(scene, back);
  CHECK(scene_to_json(back) == text);
}

// ---- a randomized scene -------------------------------------------------------

// Doubles that break naive formatting: shortest-digit cases, denormals,
// extremes, negative zero, integers past 2^53.
const double kAwkward[] = {0.1,
                           0.2,
                           0.3,
                           1.0 / 3.0,
                           1e-300,
                           -0.0,
                           0.0,
                           1e17 + 1,  // = 1e17 in double
                           std::nextafter(1e17, 2e17),
                           9007199254740993.0,  // 2^53 + 1, rounds to 2^53
                           std::nextafter(9007199254740992.0, 1e17),
                           5e-324,  // smallest denormal
                           DBL_MIN,
                           DBL_MAX,
                           -DBL_MAX,
                           DBL_EPSILON,
                           123456789.123456789,
                           -186.93724060058594,
                           4.35,
                           1e23,
                           8.41e21,
                           2.2250738585072011e-308};

struct Gen {
  std::mt19937_64 rng;
  explicit Gen(uint64_t seed) : rng(seed) {}

  double real() {
    switch (rng() % 4) {
      case 0: return kAwkward[rng() % std::size(kAwkward)];
      case 1: {  // any finite bit pattern
        for (;;) {
          const uint64_t b = rng();
          double v;
          std::memcpy(&v, &b, 8);
          if (std::isfinite(v)) return v;
        }
      }
      case 2: return std::uniform_real_distribution<double>(-2e5, 2e5)(rng);
      default: return double(int64_t(rng() % 2001) - 1000) * 0.25;
    }
  }
  int64_t id() { return rng() % 3 == 0 ? int64_t(rng()) : int64_t(rng() % 1000); }
  size_t count(size_t max) { return size_t(rng() % (max + 1)); }
  bool coin() { return rng() & 1; }
  glm::dvec3 v3() { return {real(), real(), real()}; }
  std::vector<glm::dvec3> pts(size_t max) {
    std::vector<glm::dvec3> p(count(max));
    for (auto& x : p) x = v3();
    return p;
  }
  std::vector<int64_t> ids(size_t max) {
    std::vector<int64_t> v(count(max));
    for (auto& x : v) x = id();
    return v;
  }
  std::string text() {
    static const char* const kTexts[] = {"", "front", "a \"quoted\" \\ text", "tab\tnewline\n", "ünïcødé ✓ 日本",
                                         "\x01 control"};
    return kTexts[rng() % std::size(kTexts)];
  }
  glm::dmat4 mat() {
    glm::dmat4 m(1.0);
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 3; ++r) m[c][r] = real();
    return m;
  }

  Scene scene() {
    Scene s;
    s.provenance = {text(), "waymo-scenario", text() + "637f20cafde22ff8", text()};
    s.prompt = text();
    const size_t n_times = count(12);
    double t = real();
    if (std::abs(t) > 1e15) t = 0.1;
    for (size_t i = 0; i < n_times; ++i) {
      s.timestamps.push_back(t);
      t = std::nextafter(t + std::abs(real()) * 1e-300 + 0.1, 1e300);
    }
    s.current_time_index = n_times ? int(count(n_times - 1)) : 0;
    for (size_t i = count(4); i > 0; --i)
      s.map.road_edges.push_back({id(), static_cast<RoadEdgeType>(rng() % 4), pts(6)});
    for (size_t i = count(4); i > 0; --i)
      s.map.road_lines.push_back({id(), static_cast<RoadLineType>(rng() % 9), text(), pts(6)});
    for (size_t i = count(4); i > 0; --i) {
      Lane l;
      l.id = id();
      l.type = static_cast<LaneType>(rng() % 4);
      l.speed_limit_mph = real();
      l.interpolating = coin();
      l.points = pts(6);
      l.entry_lanes = ids(3);
      l.exit_lanes = ids(3);
      l.left_neighbors = ids(3);
      l.right_neighbors = ids(3);
      s.map.lanes.push_back(l);
    }
    for (auto* polys : {&s.map.crosswalks, &s.map.driveways, &s.map.speed_bumps})
      for (size_t i = count(3); i > 0; --i) polys->push_back({id(), pts(5)});
    for (size_t i = count(3); i > 0; --i) s.map.stop_signs.push_back({id(), v3(), ids(3)});
    s.map.geo_reference = coin() ? "+proj=tmerc +lat_0=0 +lon_0=0 +k=1 +x_0=0 +y_0=0 +datum=WGS84" : "";
    for (size_t i = count(5); i > 0; --i) {
      Track tr;
      tr.id = id();
      tr.type = static_cast<ObjectType>(rng() % 6);
      tr.dynamic = coin();
      tr.instance_id = uint32_t(rng());
      for (size_t k = 0; k < n_times; ++k) {
        BoxState b;
        b.center = v3();
        b.length = real(), b.width = real(), b.height = real();
        b.heading = real(), b.pitch = real(), b.roll = real();
        b.velocity = {real(), real()};
        b.valid = coin();
        tr.states.push_back(b);
      }
      s.tracks.push_back(tr);
    }
    s.sdc_track_index = s.tracks.empty() ? -1 : int(count(s.tracks.size()) ) - 1;
    if (n_times && coin())
      for (size_t k = 0; k < n_times; ++k) s.ego.push_back({mat(), coin()});
    for (size_t i = count(2); i > 0; --i) {
      Camera c;
      c.name = text();
      c.fx = real(), c.fy = real(), c.cx = real(), c.cy = real();
      c.width = uint32_t(rng()), c.height = uint32_t(rng());
      c.camera_to_ego = mat();
      s.cameras.push_back(c);
    }
    for (size_t i = count(3); i > 0; --i) s.missing.push_back(text() + "cameras");
    return s;
  }
};

// A small valid document the error cases mutate one value at a time.
Json base_document() {
  return Json::parse(R"({
    "format": "icube-scene", "version": 1,
    "timestamps": [0.0, 0.1],
    "sdc_track_index": 0,
    "map": {
      "road_edges": [{"id": 1, "type": "boundary", "points": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]}],
      "lanes": [{"id": 2, "type": "surface_street", "points": [[0, 1, 0], [1, 1, 0]]}],
      "stop_signs": [{"id": 3, "position": [1, 2, 3], "lanes": [2]}]
    },
    "tracks": [{"id": 7, "type": "vehicle", "states": [
      {"center": [0, 0, 0], "lwh": [4, 2, 1.5], "heading": 0.5, "valid": true},
      {"center": [1, 0, 0], "lwh": [4, 2, 1.5], "heading": 0.5, "valid": true}]}],
    "ego": [{"ego_to_world": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
            {"ego_to_world": [[1, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "valid": false}],
    "cameras": [{"fx": 800, "fy": 800, "cx": 416, "cy": 240, "width": 832, "height": 480}]
  })");
}

// The InputError message for `text`, or "" when it parses.
std::string error_of(const std::string& text, const std::string& file = "s.json") {
  try {
    scene_from_json(text, file);
  } catch (const InputError& e) {
    CHECK(e.file() == file);
    return e.what();
  }
  return "";
}

std::string error_with(const char* pointer, const Json& value) {
  Json d = base_document();
  d[Json::json_pointer(pointer)] = value;
  return error_of(d.dump());
}

std::string error_without(const char* pointer) {
  Json d = base_document();
  const Json::json_pointer p(pointer);
  d[p.parent_pointer()].erase(p.back());
  return error_of(d.dump());
}

bool is_not_implemented(const std::exception& e) {
  const std::string m = e.what();
  return m.find("not implemented") != std::string::npos;
}

}  // namespace

TEST_CASE("scene_json: a randomized scene round-trips every field bit-exactly") {
  for (uint64_t seed : {1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u}) {
    CAPTURE(seed);
    const Scene s = Gen(seed).scene();
    check_round_trip(s);
  }
}

TEST_CASE("scene_json: awkward doubles keep their bit patterns") {
  Scene s;
  RoadEdge e;
  for (double v : kAwkward) e.points.push_back({v, -v, v * 0.5});
  s.map.road_edges.push_back(e);
  const std::string text = scene_to_json(s);
  const Scene back = scene_from_json(text, "awkward.json");
  REQUIRE(back.map.road_edges.size() == 1);
  const auto& got = back.map.road_edges[0].points;
  REQUIRE(got.size() == e.points.size());
  for (size_t i = 0; i < got.size(); ++i) {
    CAPTURE(e.points[i].x);
    CHECK(std::memcmp(&got[i], &e.points[i], sizeof(glm::dvec3)) == 0);
  }
  CHECK(std::signbit(got[5].x));                          // -0.0 stays negative
  CHECK(text.find("[-0.0,0.0,-0.0]") != std::string::npos);  // and is written as such
  CHECK(got[7].x == 1e17);
}

TEST_CASE("scene_json: the document starts with format and version and lists one point per line") {
  Scene s;
  s.map.road_edges.push_back({5, RoadEdgeType::Curb, {{1, 2, 3}, {4.5, 5, 6}}});
  const std::string text = scene_to_json(s);
  CHECK(text.rfind("{\n  \"format\": \"icube-scene\",\n  \"version\": 1,\n", 0) == 0);
  CHECK(text.find("\"type\": \"curb\"") != std::string::npos);
  CHECK(text.find("\n          [1.0,2.0,3.0],\n          [4.5,5.0,6.0]\n") != std::string::npos);
}

TEST_CASE("scene_json: the writer refuses NaN and infinity, naming the value") {
  Scene s = Gen(11).scene();
  s.timestamps = {0.0, 0.1, 0.2};
  s.tracks.assign(2, Track{});
  for (Track& t : s.tracks) t.states.assign(3, BoxState{});
  s.ego.clear();
  s.tracks[1].states[2].heading = std::nan("");
  try {
    scene_to_json(s);
    FAIL("no error");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()) == "scene_to_json: tracks[1].states[2].heading is NaN; "
                                   "the scene format stores finite numbers only");
  }
  s.tracks[1].states[2].heading = 0;
  s.map.lanes.assign(1, Lane{});
  s.map.lanes[0].points = {{0, 0, 0}, {0, std::numeric_limits<double>::infinity(), 0}};
  CHECK_THROWS_WITH_AS(scene_to_json(s), doctest::Contains("map.lanes[0].points[1][1] is +infinity"), std::runtime_error);
}

TEST_CASE("scene_json: the writer refuses strings that are not UTF-8, naming them") {
  Scene s;
  s.provenance.scenario_id = "Stra\xDF" "e";  // Latin-1 sharp s
  CHECK_THROWS_WITH_AS(scene_to_json(s),
                       "scene_to_json: provenance.scenario_id: string is not valid UTF-8 (byte 4)", std::runtime_error);
  s.provenance.scenario_id = "\xED\xA0\x80";  // an encoded surrogate
  CHECK_THROWS_AS(scene_to_json(s), std::runtime_error);
  s.provenance.scenario_id = "Stra\xC3\x9F" "e \xF0\x9F\x9A\x97";  // valid: ß and an emoji
  CHECK_NOTHROW(scene_to_json(s));
}

TEST_CASE("scene_json: the base document of the error cases is valid") {
  Diagnostics diag;
  const Scene s = scene_from_json(base_document().dump(), "s.json", &diag);
  CHECK(diag.warnings.empty());
  CHECK(s.tracks.size() == 1);
  CHECK(s.ego.size() == 2);
  CHECK(s.ego[1].valid == false);
  CHECK(s.ego[1].ego_to_world[3][0] == 1.0);  // row 0, column 3 = translation x
  CHECK(s.cameras.size() == 1);
}

TEST_CASE("scene_json: malformed JSON names the file, line and column") {
  CHECK(error_of("{\n  \"format\": \"icube-scene\",\n  \"version\": 1,,\n}", "bad.json") ==
        "bad.json: line 3, column 16: syntax error while parsing object key - unexpected ','; "
        "expected string literal");
  CHECK(error_of("", "empty.json") ==
        "empty.json: line 1, column 1: syntax error while parsing value - unexpected end of input; "
        "expected '[', '{', or a literal");
  CHECK(error_of("{\"format\": \"icube-scene\", \"version\": 1, \"timestamps\": [NaN]}") ==
        "s.json: line 1, column 56: syntax error while parsing value - invalid literal; last read: '\"timestamps\": [N'");
  CHECK(error_of("{\"format\": \"icube-scene\", \"version\": 1, \"timestamps\": [Infinity]}").find("invalid literal") !=
        std::string::npos);
  CHECK(error_of("{\"format\": \"icube-scene\",\n\"version\": 1, \"prompt\": \"a\xFF\"}").find("s.json: line 2, column") ==
        0);
}

TEST_CASE("scene_json: numbers too large for a double are rejected with their line") {
  CHECK(error_of("{\"format\": \"icube-scene\",\n \"version\": 1,\n \"timestamps\": [1e400]}") ==
        "s.json: line 3, column 17: number overflow parsing '1e400'");
}

TEST_CASE("scene_json: wrong types name the JSON path") {
  CHECK(error_with("/tracks/0/states/1/center/1", "nan") ==
        "s.json: tracks[0].states[1].center[1]: expected a number, got a string");
  CHECK(error_with("/version", "1") == "s.json: version: expected an integer, got a string");
  CHECK(error_with("/tracks/0/id", 1.5) == "s.json: tracks[0].id: expected an integer, got a number");
  CHECK(error_with("/tracks/0/states/0/valid", 1) ==
        "s.json: tracks[0].states[0].valid: expected a boolean (true/false), got an integer");
  CHECK(error_with("/map/road_edges/0/points/2", Json::array({1, 2})) ==
        "s.json: map.road_edges[0].points[2]: expected 3 elements, got 2");
  CHECK(error_with("/map/road_edges/0/points", Json::object()) ==
        "s.json: map.road_edges[0].points: expected an array, got an object");
  CHECK(error_with("/map/lanes/0/type", "highway") ==
        "s.json: map.lanes[0].type: unknown value 'highway' (expected one of: undefined, freeway, surface_street, "
        "bike_lane)");
  CHECK(error_with("/map/stop_signs/0/lanes/0", nullptr) ==
        "s.json: map.stop_signs[0].lanes[0]: expected an integer, got null");
  CHECK(error_with("/cameras/0/width", -1) ==
        "s.json: cameras[0].width: integer -1 is out of range [0, 4294967295]");
  CHECK(error_with("/tracks/0/instance_id", uint64_t(4294967296)) ==
        "s.json: tracks[0].instance_id: integer 4294967296 is out of range [0, 4294967295]");
  CHECK(error_with("/map/lanes/0/id", std::numeric_limits<uint64_t>::max()) ==
        "s.json: map.lanes[0].id: integer 18446744073709551615 is out of range");
  CHECK(error_with("/ego/1/ego_to_world/3", Json::array({0, 0, 1, 1})) ==
        "s.json: ego[1].ego_to_world[3]: the last row of a rigid transform must be [0, 0, 0, 1]");
  CHECK(error_with("/map", Json::array()) == "s.json: map: expected an object, got an array");
  CHECK(error_of("[]") == "s.json: expected a JSON object at the top level, got an array");
}

TEST_CASE("scene_json: missing required keys name the enclosing object") {
  CHECK(error_without("/tracks/0/states/1/center") == "s.json: tracks[0].states[1]: missing required key 'center'");
  CHECK(error_without("/map/stop_signs/0/position") ==
        "s.json: map.stop_signs[0]: missing required key 'position'");
  CHECK(error_without("/cameras/0/fy") == "s.json: cameras[0]: missing required key 'fy'");
  CHECK(error_without("/ego/0/ego_to_world") == "s.json: ego[0]: missing required key 'ego_to_world'");
  CHECK(error_without("/version") == "s.json: missing required key 'version'");
  CHECK(error_without("/format") == "s.json: missing required key 'format' (not an icube scene file?)");
}

TEST_CASE("scene_json: format and version are checked first") {
  CHECK(error_with("/version", 2) ==
        "s.json: version: version 2 is newer than this build reads (version 1); update icube");
  CHECK(error_with("/version", 0) == "s.json: version: unsupported version 0");
  CHECK(error_with("/format", "geojson") == "s.json: format: format is 'geojson', expected 'icube-scene'");
  // A newer version is reported even when the rest would not parse.
  CHECK(error_of(R"({"format": "icube-scene", "version": 3, "tracks": 5})") ==
        "s.json: version: version 3 is newer than this build reads (version 1); update icube");
}

TEST_CASE("scene_json: model invariants are checked with paths") {
  CHECK(error_with("/timestamps", Json::array({0.0, 0.1, 0.1})) ==
        "s.json: timestamps[2]: timestamps must increase (0.1 after 0.1)");
  CHECK(error_with("/timestamps", Json::array({0.0, 0.1, 0.2})).find(
            "s.json: tracks[0].states: has 2 states but the scene has 3 timestamps") == 0);
  {
    Json d = base_document();
    d["ego"].erase(1);
    CHECK(error_of(d.dump()).find("s.json: ego: has 1 poses but the scene has 2 timestamps") == 0);
  }
  CHECK(error_with("/sdc_track_index", 1) == "s.json: sdc_track_index: 1 is not -1 or a track index (1 tracks)");
  CHECK(error_with("/sdc_track_index", -2).find("s.json: sdc_track_index: -2 is not") == 0);
  CHECK(error_with("/current_time_index", 2) ==
        "s.json: current_time_index: 2 is not a timestamp index (2 timestamps)");
}

TEST_CASE("scene_json: optional fields take their defaults") {
  const Scene s = scene_from_json(R"({"format": "icube-scene", "version": 1})", "min.json");
  const Scene def;
  check_same(s, def);

  const Scene t = scene_from_json(base_document().dump(), "s.json");
  const BoxState& b = t.tracks[0].states[0];
  CHECK(b.pitch == 0.0);
  CHECK(b.roll == 0.0);
  CHECK(b.velocity == glm::dvec2(0.0));
  CHECK(t.tracks[0].dynamic == false);
  CHECK(t.tracks[0].instance_id == 0);
  CHECK(t.map.road_edges[0].type == RoadEdgeType::Boundary);
  CHECK(t.ego[0].valid == true);
  CHECK(t.cameras[0].name == "front");
  CHECK(t.cameras[0].camera_to_ego == glm::dmat4(1.0));
  CHECK(t.current_time_index == 0);
}

TEST_CASE("scene_json: unknown keys become warnings with their place") {
  Json d = base_document();
  d["colour"] = "red";
  d["tracks"][0]["extra"] = 1;
  d["map"]["lanes"][0]["width"] = 3.5;
  Diagnostics diag;
  const Scene s = scene_from_json(d.dump(), "s.json", &diag);
  CHECK(diag.warnings == std::vector<std::string>{"s.json: unknown key 'colour' ignored",
                                                  "s.json: map.lanes[0]: unknown key 'width' ignored",
                                                  "s.json: tracks[0]: unknown key 'extra' ignored"});
  CHECK(s.tracks.size() == 1);
  CHECK_NOTHROW(scene_from_json(d.dump(), "s.json", nullptr));
}

TEST_CASE("scene_json: deeply nested input is an error, not a crash") {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  CHECK(error_of(deep) == "s.json: expected a JSON object at the top level, got an array");
  const std::string inside = R"({"format": "icube-scene", "version": 1, "timestamps": [)" + deep + "]}";
  CHECK(error_of(inside) == "s.json: timestamps[0]: expected a number, got an array");
}

TEST_CASE("scene_json: write_scene_json is atomic and read_scene_json reads it back") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("icube-test-scene-json-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Scene s = Gen(99).scene();
  const std::string path = (dir / "scene.json").string();
  {
    std::ofstream(path) << "old contents";
  }
  write_scene_json(s, path);
  check_same(s, read_scene_json(path));
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file() ? 1 : 0;
  CHECK(files == 1);  // no temporary left behind
  CHECK_THROWS_AS(write_scene_json(s, (dir / "no-such-dir" / "x.json").string()), std::runtime_error);
  CHECK_THROWS_WITH_AS(read_scene_json((dir / "missing.json").string()), doctest::Contains("missing.json: cannot open"),
                       InputError);
  fs::remove_all(dir);
}

TEST_CASE("scene_json: the example in docs/scene-format.md reads and is written back byte for byte") {
  const std::string doc = read_file(std::string(ICUBE_SOURCE_DIR) + "/docs/scene-format.md");
  const size_t begin = doc.find("```json\n");
  REQUIRE(begin != std::string::npos);
  const size_t end = doc.find("```", begin + 8);
  REQUIRE(end != std::string::npos);
  const std::string example = doc.substr(begin + 8, end - begin - 8);
  Diagnostics diag;
  const Scene s = scene_from_json(example, "scene-format.md", &diag);
  CHECK(diag.warnings.empty());
  CHECK(s.tracks.size() == 2);
  CHECK(s.cameras.size() == 1);
  CHECK(scene_to_json(s) == example);
}

TEST_CASE("scene_json: the real Waymo scenario round-trips bit-exactly") {
  const std::string data = icube::test::test_data_dir();
  if (data.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  Scene s;
  try {
    s = read_waymo_scenario(data + "/maps/waymo/motion_data_one_scenario.tfrecord");
  } catch (const std::exception& e) {
    if (!is_not_implemented(e)) throw;
    MESSAGE("skipped: ", std::string(e.what()));
    return;
  }
  CHECK(s.tracks.size() == 83);
  CHECK(s.timestamps.size() == 91);
  check_round_trip(s);
}

TEST_CASE("scene_json: OpenDRIVE maps round-trip bit-exactly") {
  const std::string data = icube::test::test_data_dir();
  if (data.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  for (const char* name : {"carla/Town01.xodr", "esmini/velodrome.xodr", "esmini/fabriksgatan.xodr"}) {
    const std::string file_name = name;
    CAPTURE(file_name);
    Scene s;
    try {
      s = read_opendrive(data + "/maps/opendrive/" + name);
    } catch (const std::exception& e) {
      if (!is_not_implemented(e)) throw;
      MESSAGE("skipped: ", std::string(e.what()));
      return;
    }
    CHECK(!s.map.road_edges.empty());
    check_round_trip(s);
  }
}
