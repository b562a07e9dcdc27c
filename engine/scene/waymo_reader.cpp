// Waymo Open Motion Dataset reader: TFRecord framing (tfrecord.h) around
// serialized `Scenario` messages, decoded with the wire reader in
// protobuf_wire.h against the field numbers of formats.md §1.3.
//
// Decisions (the header says what is read; these say how):
// - Ego frame: the ego (FLU) origin is on the ground below the centre of the
//   SDC track's box, i.e. ego_to_world = T(center_x, center_y, center_z -
//   height / 2) · Rz(heading), x forward along the heading, z up. The motion
//   dataset gives the SDC only as a box, not the origin of its vehicle frame,
//   so the box centre is the best available point, and the ground below it
//   places ego-relative things (cameras) relative to the road. Invalid SDC
//   states give an identity pose with valid = false.
// - Tracks: exactly one state per timestamp. Short tracks are padded with
//   invalid states, long ones truncated (a warning each). Non-finite values in
//   a valid state are an InputError; in an invalid state they are set to 0.
//   Headings outside [-pi, pi) are wrapped into it.
// - Map: non-finite point coordinates are an InputError naming the feature
//   id. Lanes, road lines and road edges without points, polygons with fewer
//   than 3 (after dropping a closing point equal to the first), stop signs
//   without a position and features with no geometry are dropped with a
//   warning; single-point polylines (real files have lane stubs) are kept
//   with a warning. Unknown enum values become the enum's 0 value with a warning.
// - sdc_track_index absent: no ego trajectory ("ego trajectory" in missing);
//   present but out of range: InputError. current_time_index must index
//   timestamps_seconds, which must be finite and strictly increasing.
// - Not read: dynamic_map_states (traffic signals), objects_of_interest,
//   tracks_to_predict, lane boundaries, camera/laser data. The motion dataset
//   has no cameras, so "cameras" is always in Scene::missing.
// - Allocation stays linear in the input: every decoded element costs at
//   least one input byte, and padding short tracks may add at most one
//   invalid state per payload byte (else InputError). At most 100 warnings
//   per scenario are listed, then one line counting the rest.
// - Files: the framing (lengths and their CRCs) of every record is checked
//   before any record is decoded, so a truncated tail is an error whatever
//   the selector; payload CRCs are checked for the records that are read
//   (all of them when selecting by id or listing).
#include "scene/waymo_reader.h"

#include "scene/atomic_file.h"
#include "scene/protobuf_wire.h"
#include "scene/tfrecord.h"

#include <cmath>
#include <cstdio>
#include <limits>

namespace icube::scene {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Warnings per scenario; the rest are counted in one final line.
constexpr size_t kMaxWarnings = 100;

struct Context {
  const std::string& file;
  const std::string& where;  // "record 3", or the caller's label
  Diagnostics* diag;
  mutable size_t warnings = 0;
  void warn(const std::string& at, const std::string& what) const {
    if (diag && ++warnings <= kMaxWarnings) diag->warn(file, at, what);
  }
  void finish_warnings() const {
    if (diag && warnings > kMaxWarnings)
      diag->warn(file, where, std::to_string(warnings - kMaxWarnings) + " more warnings not shown");
  }
};

std::string number_text(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// ---- enums ----------------------------------------------------------------------

// Returns the enum value, or 0 with a warning when it is outside [0, max].
int checked_enum(const WireReader& r, int max, const char* enum_name, const Context& ctx) {
  const int32_t v = r.int32();
  if (v >= 0 && v <= max) return v;
  ctx.warn(r.where_at(r.field_offset()), std::string("unknown ") + enum_name + " " + std::to_string(v) + "; using 0");
  return 0;
}

ObjectType object_type_from_waymo(int v) {
  switch (v) {
    case 1: return ObjectType::Vehicle;
    case 2: return ObjectType::Pedestrian;
    case 3: return ObjectType::Cyclist;
    case 4: return ObjectType::Other;
    default: return ObjectType::Unset;
  }
}

// ---- map features ---------------------------------------------------------------

enum class FeatureKind { None, Lane, RoadLine, RoadEdge, StopSign, Crosswalk, SpeedBump, Driveway };

const char* feature_kind_name(FeatureKind k) {
  switch (k) {
    case FeatureKind::Lane: return "lane";
    case FeatureKind::RoadLine: return "road_line";
    case FeatureKind::RoadEdge: return "road_edge";
    case FeatureKind::StopSign: return "stop_sign";
    case FeatureKind::Crosswalk: return "crosswalk";
    case FeatureKind::SpeedBump: return "speed_bump";
    case FeatureKind::Driveway: return "driveway";
    default: return "empty";
  }
}

struct Feature {
  int64_t id = 0;
  FeatureKind kind = FeatureKind::None;
  Lane lane;
  RoadLine line;
  RoadEdge edge;
  StopSign stop;
  bool stop_has_position = false;
  Polygon polygon;

  // The geometry is a oneof: a different member replaces, the same one merges.
  void set_kind(FeatureKind k) {
    if (k == kind) return;
    lane = {};
    line = {};
    edge = {};
    stop = {};
    stop_has_position = false;
    polygon = {};
    kind = k;
  }
};

// MapPoint fields merge into `p` (a repeated singular field: last value wins).
void decode_point(WireReader r, glm::dvec3& p) {
  while (r.next()) {
    switch (r.field()) {
      case 1: p.x = r.float64(); break;
      case 2: p.y = r.float64(); break;
      case 3: p.z = r.float64(); break;
      default: break;
    }
  }
}

void append_point(const WireReader& parent, const char* name, std::vector<glm::dvec3>& points) {
  glm::dvec3 p(0.0);
  decode_point(parent.message(name, points.size()), p);
  points.push_back(p);
}

int64_t decode_neighbor_id(WireReader r) {
  int64_t id = 0;
  while (r.next())
    if (r.field() == 1) id = r.int64();
  return id;
}

void decode_lane(WireReader r, Lane& lane, const Context& ctx) {
  while (r.next()) {
    switch (r.field()) {
      case 1: lane.speed_limit_mph = r.float64(); break;
      case 2: lane.type = static_cast<LaneType>(checked_enum(r, 3, "LaneType", ctx)); break;
      case 3: lane.interpolating = r.boolean(); break;
      case 8: append_point(r, "polyline", lane.points); break;
      case 9: r.repeated_int64(lane.entry_lanes); break;
      case 10: r.repeated_int64(lane.exit_lanes); break;
      case 11: lane.left_neighbors.push_back(decode_neighbor_id(r.message("left_neighbors", lane.left_neighbors.size()))); break;
      case 12: lane.right_neighbors.push_back(decode_neighbor_id(r.message("right_neighbors", lane.right_neighbors.size()))); break;
      default: break;  // left/right_boundaries (13, 14), unknown fields
    }
  }
}

// RoadLine and RoadEdge share the layout: type = 1, polyline = 2.
template <class Line>
void decode_line(WireReader r, Line& line, int max_type, const char* enum_name, const Context& ctx) {
  while (r.next()) {
    switch (r.field()) {
      case 1: line.type = static_cast<decltype(line.type)>(checked_enum(r, max_type, enum_name, ctx)); break;
      case 2: append_point(r, "polyline", line.points); break;
      default: break;
    }
  }
}

void decode_stop_sign(WireReader r, Feature& f) {
  while (r.next()) {
    switch (r.field()) {
      case 1: r.repeated_int64(f.stop.lanes); break;
      case 2:
        decode_point(r.message("position"), f.stop.position);
        f.stop_has_position = true;
        break;
      default: break;
    }
  }
}

void decode_polygon(WireReader r, Polygon& polygon) {
  while (r.next())
    if (r.field() == 1) append_point(r, "polygon", polygon.points);
}

Feature decode_feature(WireReader r, const Context& ctx) {
  Feature f;
  while (r.next()) {
    switch (r.field()) {
      case 1: f.id = r.int64(); break;
      case 3:
        f.set_kind(FeatureKind::Lane);
        decode_lane(r.message("lane"), f.lane, ctx);
        break;
      case 4:
        f.set_kind(FeatureKind::RoadLine);
        decode_line(r.message("road_line"), f.line, 8, "RoadLineType", ctx);
        break;
      case 5:
        f.set_kind(FeatureKind::RoadEdge);
        decode_line(r.message("road_edge"), f.edge, 2, "RoadEdgeType", ctx);
        break;
      case 7:
        f.set_kind(FeatureKind::StopSign);
        decode_stop_sign(r.message("stop_sign"), f);
        break;
      case 8:
        f.set_kind(FeatureKind::Crosswalk);
        decode_polygon(r.message("crosswalk"), f.polygon);
        break;
      case 9:
        f.set_kind(FeatureKind::SpeedBump);
        decode_polygon(r.message("speed_bump"), f.polygon);
        break;
      case 10:
        f.set_kind(FeatureKind::Driveway);
        decode_polygon(r.message("driveway"), f.polygon);
        break;
      default: break;
    }
  }
  return f;
}

void check_points_finite(const std::vector<glm::dvec3>& points, const Context& ctx, const std::string& where) {
  static const char* axis[3] = {"x", "y", "z"};
  for (size_t i = 0; i < points.size(); ++i)
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(points[i][a]))
        throw InputError(ctx.file, where, "point " + std::to_string(i) + ": " + axis[a] + " is " + number_text(points[i][a]));
}

// Validates one decoded feature and adds it to the map (or drops it with a warning).
void add_feature(Feature& f, size_t index, uint64_t offset, const Context& ctx, Map& map) {
  const std::string where = ctx.where + ", map feature " + std::to_string(f.id) + " (map_features[" +
                            std::to_string(index) + "], " + feature_kind_name(f.kind) + ", at byte " +
                            std::to_string(offset) + ")";
  auto keep_line = [&](std::vector<glm::dvec3>& points) {
    check_points_finite(points, ctx, where);
    if (points.size() >= 2) return true;
    if (points.size() == 1) {  // real files have these (lane stubs); a point still conditions the map
      ctx.warn(where, "polyline has 1 point; kept as a single point");
      return true;
    }
    ctx.warn(where, "polyline has no points; dropped");
    return false;
  };
  auto keep_polygon = [&](std::vector<glm::dvec3>& points) {
    check_points_finite(points, ctx, where);
    if (points.size() >= 2 && points.back() == points.front()) points.pop_back();  // closed: last not repeated
    if (points.size() >= 3) return true;
    ctx.warn(where, "polygon has " + std::to_string(points.size()) + " distinct point(s), needs 3; dropped");
    return false;
  };
  switch (f.kind) {
    case FeatureKind::Lane:
      f.lane.id = f.id;
      if (!std::isfinite(f.lane.speed_limit_mph)) {
        ctx.warn(where, "speed_limit_mph is " + number_text(f.lane.speed_limit_mph) + "; using 0");
        f.lane.speed_limit_mph = 0.0;
      }
      if (keep_line(f.lane.points)) map.lanes.push_back(std::move(f.lane));
      break;
    case FeatureKind::RoadLine:
      f.line.id = f.id;
      if (keep_line(f.line.points)) map.road_lines.push_back(std::move(f.line));
      break;
    case FeatureKind::RoadEdge:
      f.edge.id = f.id;
      if (keep_line(f.edge.points)) map.road_edges.push_back(std::move(f.edge));
      break;
    case FeatureKind::StopSign:
      f.stop.id = f.id;
      if (!f.stop_has_position) {
        ctx.warn(where, "stop sign has no position; dropped");
        break;
      }
      check_points_finite({f.stop.position}, ctx, where + " position");
      map.stop_signs.push_back(std::move(f.stop));
      break;
    case FeatureKind::Crosswalk:
    case FeatureKind::SpeedBump:
    case FeatureKind::Driveway: {
      f.polygon.id = f.id;
      if (!keep_polygon(f.polygon.points)) break;
      auto& list = f.kind == FeatureKind::Crosswalk ? map.crosswalks
                   : f.kind == FeatureKind::SpeedBump ? map.speed_bumps
                                                      : map.driveways;
      list.push_back(std::move(f.polygon));
      break;
    }
    case FeatureKind::None: ctx.warn(where, "feature has no geometry; dropped"); break;
  }
}

// ---- tracks ---------------------------------------------------------------------

BoxState decode_state(WireReader r) {
  BoxState s;
  while (r.next()) {
    switch (r.field()) {
      case 2: s.center.x = r.float64(); break;
      case 3: s.center.y = r.float64(); break;
      case 4: s.center.z = r.float64(); break;
      case 5: s.length = static_cast<double>(r.float32()); break;
      case 6: s.width = static_cast<double>(r.float32()); break;
      case 7: s.height = static_cast<double>(r.float32()); break;
      case 8: s.heading = static_cast<double>(r.float32()); break;
      case 9: s.velocity.x = static_cast<double>(r.float32()); break;
      case 10: s.velocity.y = static_cast<double>(r.float32()); break;
      case 11: s.valid = r.boolean(); break;
      default: break;
    }
  }
  return s;
}

// Valid states must be finite (InputError); invalid ones are sanitised.
void check_state(BoxState& s, size_t state_index, const Context& ctx, const std::string& where) {
  struct Value {
    const char* name;
    double* v;
  } values[] = {{"center_x", &s.center.x}, {"center_y", &s.center.y}, {"center_z", &s.center.z},
                {"length", &s.length},     {"width", &s.width},       {"height", &s.height},
                {"heading", &s.heading},   {"velocity_x", &s.velocity.x}, {"velocity_y", &s.velocity.y}};
  for (const Value& v : values) {
    if (std::isfinite(*v.v)) continue;
    if (s.valid)
      throw InputError(ctx.file, where,
                       "state " + std::to_string(state_index) + " is valid but " + v.name + " is " + number_text(*v.v));
    *v.v = 0.0;
  }
  if (s.heading < -kPi || s.heading >= kPi) {
    s.heading = std::remainder(s.heading, 2.0 * kPi);
    if (s.heading >= kPi) s.heading -= 2.0 * kPi;
  }
}

std::string track_where(const Context& ctx, const Track& t, size_t index, uint64_t offset) {
  return ctx.where + ", track " + std::to_string(t.id) + " (tracks[" + std::to_string(index) + "], at byte " +
         std::to_string(offset) + ")";
}

Track decode_track(WireReader r, size_t index, const Context& ctx) {
  Track t;
  while (r.next()) {
    switch (r.field()) {
      case 1: t.id = r.int32(); break;
      case 2: t.type = object_type_from_waymo(checked_enum(r, 4, "ObjectType", ctx)); break;
      case 3: t.states.push_back(decode_state(r.message("states", t.states.size()))); break;
      default: break;
    }
  }
  const std::string where = track_where(ctx, t, index, r.start_offset());
  for (size_t i = 0; i < t.states.size(); ++i) check_state(t.states[i], i, ctx, where);
  return t;
}

// ---- the scenario ---------------------------------------------------------------

void check_timestamps(const std::vector<double>& ts, const Context& ctx) {
  for (size_t i = 0; i < ts.size(); ++i) {
    const std::string where = ctx.where + ", timestamps_seconds[" + std::to_string(i) + "]";
    if (!std::isfinite(ts[i])) throw InputError(ctx.file, where, "timestamp is " + number_text(ts[i]));
    if (i > 0 && !(ts[i] > ts[i - 1]))
      throw InputError(ctx.file, where,
                       "timestamp " + number_text(ts[i]) + " s is not after the previous one (" + number_text(ts[i - 1]) +
                           " s)");
  }
}

// One state per timestamp; bounded so that padding cannot outgrow the input.
void fit_tracks_to_timestamps(Scene& scene, const std::vector<uint64_t>& track_offsets, size_t payload_size,
                              const Context& ctx) {
  const size_t steps = scene.timestamps.size();
  uint64_t padding = 0;
  for (const Track& t : scene.tracks)
    if (t.states.size() < steps) padding += steps - t.states.size();
  if (padding > payload_size)
    throw InputError(ctx.file, ctx.where,
                     "tracks are short of " + std::to_string(padding) + " states for " + std::to_string(steps) +
                         " timestamps, more than the " + std::to_string(payload_size) +
                         "-byte scenario could describe; the scenario is malformed");
  for (size_t i = 0; i < scene.tracks.size(); ++i) {
    Track& t = scene.tracks[i];
    const std::string where = track_where(ctx, t, i, track_offsets[i]);
    if (t.states.size() != steps) {
      const size_t had = t.states.size();
      t.states.resize(steps);  // new states are default BoxStates: valid = false
      ctx.warn(where, std::to_string(had) + " states for " + std::to_string(steps) + " timestamps; " +
                          (had < steps ? "padded with invalid states" : "truncated"));
    }
    bool any_valid = false;
    for (const BoxState& s : t.states) any_valid = any_valid || s.valid;
    if (!any_valid && steps > 0) ctx.warn(where, "track has no valid state");
  }
}

// See the top of the file: origin on the ground below the box centre, x along the heading.
EgoPose ego_pose_from_box(const BoxState& s) {
  EgoPose pose;
  pose.valid = s.valid;
  if (!s.valid) return pose;  // identity
  const double c = std::cos(s.heading), sn = std::sin(s.heading);
  glm::dmat4 m(1.0);
  m[0] = glm::dvec4(c, sn, 0.0, 0.0);
  m[1] = glm::dvec4(-sn, c, 0.0, 0.0);
  m[3] = glm::dvec4(s.center.x, s.center.y, s.center.z - 0.5 * s.height, 1.0);
  pose.ego_to_world = m;
  return pose;
}

Scene decode_scenario(const uint8_t* data, size_t size, const std::string& file, const std::string& where,
                      uint64_t base, Diagnostics* diag) {
  const Context ctx{file, where, diag};
  WireOrigin origin;
  origin.file = file;
  origin.where = where;
  origin.base = base;
  origin.root_name = "Scenario";
  WireReader r(data, size, origin);

  Scene scene;
  std::vector<uint64_t> track_offsets;
  bool has_sdc = false;
  int32_t sdc = 0, current = 0;
  size_t feature_index = 0;
  while (r.next()) {
    switch (r.field()) {
      case 1: r.repeated_double(scene.timestamps); break;
      case 2: {
        WireReader t = r.message("tracks", scene.tracks.size());
        track_offsets.push_back(t.start_offset());
        scene.tracks.push_back(decode_track(t, scene.tracks.size(), ctx));
        break;
      }
      case 5: scene.provenance.scenario_id = std::string(r.bytes()); break;
      case 6:
        sdc = r.int32();
        has_sdc = true;
        break;
      case 8: {
        WireReader f = r.message("map_features", feature_index);
        Feature feature = decode_feature(f, ctx);
        add_feature(feature, feature_index++, f.start_offset(), ctx, scene.map);
        break;
      }
      case 10: current = r.int32(); break;
      default: break;  // objects_of_interest, dynamic_map_states, tracks_to_predict, sensor data, unknown
    }
  }

  scene.provenance.source_file = file;
  scene.provenance.source_format = "waymo-scenario";
  if (scene.provenance.scenario_id.empty()) ctx.warn(where, "scenario has no scenario_id");

  check_timestamps(scene.timestamps, ctx);
  const size_t steps = scene.timestamps.size();
  if (current < 0 || (steps > 0 && size_t(current) >= steps) || (steps == 0 && current != 0))
    throw InputError(file, where + ", current_time_index",
                     std::to_string(current) + " is out of range (" + std::to_string(steps) + " timestamps)");
  scene.current_time_index = current;

  fit_tracks_to_timestamps(scene, track_offsets, size, ctx);

  if (has_sdc) {
    if (sdc < 0 || size_t(sdc) >= scene.tracks.size())
      throw InputError(file, where + ", sdc_track_index",
                       std::to_string(sdc) + " is out of range (" + std::to_string(scene.tracks.size()) + " tracks)");
    scene.sdc_track_index = sdc;
    bool any_valid = false;
    for (const BoxState& s : scene.tracks[size_t(sdc)].states) {
      scene.ego.push_back(ego_pose_from_box(s));
      any_valid = any_valid || s.valid;
    }
    if (!any_valid) scene.missing.push_back("ego trajectory");
  } else {
    if (!scene.tracks.empty()) ctx.warn(where, "no sdc_track_index; the scene has no ego trajectory");
    scene.missing.push_back("ego trajectory");
  }
  if (scene.tracks.empty()) scene.missing.push_back("object boxes");
  scene.missing.push_back("cameras");

  classify_tracks(scene);
  ctx.finish_warnings();
  return scene;
}

// ---- files ----------------------------------------------------------------------

std::string scan_scenario_id(const std::string& bytes, const TfRecordSpan& rec, size_t index, const std::string& file) {
  WireOrigin origin;
  origin.file = file;
  origin.where = "record " + std::to_string(index);
  origin.base = rec.payload_offset;
  origin.root_name = "Scenario";
  WireReader r(reinterpret_cast<const uint8_t*>(bytes.data()) + rec.payload_offset, size_t(rec.length), origin);
  std::string id;
  while (r.next())
    if (r.field() == 5) id = std::string(r.bytes());
  return id;
}

// Parses an all-digits selector; false if it does not fit in size_t.
bool parse_index(const std::string& s, size_t& out) {
  size_t v = 0;
  for (char c : s) {
    const size_t d = size_t(c - '0');
    if (v > (std::numeric_limits<size_t>::max() - d) / 10) return false;
    v = v * 10 + d;
  }
  out = v;
  return true;
}

std::string id_list(const std::vector<WaymoRecordInfo>& infos) {
  constexpr size_t kShown = 10;
  std::string s;
  for (size_t i = 0; i < infos.size() && i < kShown; ++i)
    s += (i ? ", " : "") + std::to_string(i) + ":'" + printable(infos[i].scenario_id) + "'";
  if (infos.size() > kShown) s += ", ... (" + std::to_string(infos.size() - kShown) + " more)";
  return s;
}

std::vector<WaymoRecordInfo> record_infos(const std::string& bytes, const std::vector<TfRecordSpan>& spans,
                                          const std::string& path) {
  std::vector<WaymoRecordInfo> infos;
  for (size_t i = 0; i < spans.size(); ++i) {
    check_tfrecord_payload(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), spans[i], i, path);
    infos.push_back({spans[i].offset, spans[i].length, scan_scenario_id(bytes, spans[i], i, path)});
  }
  return infos;
}

std::string plural(size_t n, const char* word) { return std::to_string(n) + " " + word + (n == 1 ? "" : "s"); }

// Index of the first record whose scenario id is `id`, or infos.size().
size_t find_scenario(const std::vector<WaymoRecordInfo>& infos, const std::string& id) {
  for (size_t k = 0; k < infos.size(); ++k)
    if (infos[k].scenario_id == id) return k;
  return infos.size();
}

}  // namespace

std::vector<WaymoRecordInfo> list_waymo_records(const std::string& path) {
  const std::string bytes = read_file(path);
  const auto spans = frame_tfrecords(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), path,
                                     {.length_crc = true, .payload_crc = false});
  return record_infos(bytes, spans, path);
}

Scene parse_waymo_scenario(const uint8_t* data, size_t size, const std::string& file, const std::string& where,
                           Diagnostics* diag) {
  return decode_scenario(data, size, file, where, 0, diag);
}

Scene read_waymo_scenario(const std::string& path, const std::string& selector, Diagnostics* diag) {
  const std::string bytes = read_file(path);
  const uint8_t* data = reinterpret_cast<const uint8_t*>(bytes.data());
  // Framing and length CRCs of every record; payload CRCs only of those decoded.
  const auto spans = frame_tfrecords(data, bytes.size(), path, {.length_crc = true, .payload_crc = false});
  if (spans.empty()) throw InputError(path, "", "the file holds no TFRecord records (it is empty)");

  size_t index = 0;
  const bool digits = !selector.empty() && selector.find_first_not_of("0123456789") == std::string::npos;
  if (digits) {
    size_t i = 0;
    if (parse_index(selector, i) && i < spans.size()) {
      index = i;
    } else {
      // An all-digits scenario id is still found by id when it is no valid index.
      const auto infos = record_infos(bytes, spans, path);
      const size_t found = find_scenario(infos, selector);
      if (found == infos.size())
        throw InputError(path, "selector '" + printable(selector) + "'",
                         "record index out of range: the file holds " + plural(spans.size(), "record") +
                             " (indices 0.." + std::to_string(spans.size() - 1) + ")");
      index = found;
    }
  } else if (!selector.empty()) {
    const auto infos = record_infos(bytes, spans, path);
    const size_t found = find_scenario(infos, selector);
    if (found == infos.size())
      throw InputError(path, "selector '" + printable(selector) + "'",
                       "no scenario with this id among " + plural(infos.size(), "record") + ": " + id_list(infos));
    index = found;
  }

  const TfRecordSpan& rec = spans[index];
  check_tfrecord_payload(data, bytes.size(), rec, index, path);
  Scene scene =
      decode_scenario(data + rec.payload_offset, size_t(rec.length), path, "record " + std::to_string(index),
                      rec.payload_offset, diag);
  return scene;
}

}  // namespace icube::scene
