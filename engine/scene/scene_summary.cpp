// summarize() and format_summary(): counts, extents, time span and ego path
// of a Scene (see scene_summary.h).
#include "scene/scene_summary.h"

#include <algorithm>
#include <cstdarg>
#include <cstdio>

namespace icube::scene {

namespace {

template <size_t N, class E>
void count_type(std::array<size_t, N>& counts, E type) {
  const int v = static_cast<int>(type);
  ++counts[v >= 0 && size_t(v) < N ? size_t(v) : 0];
}

void extend(SceneSummary& s, const glm::dvec3& p) {
  if (!s.has_map_extent) {
    s.map_min = s.map_max = p;
    s.has_map_extent = true;
  } else {
    s.map_min = glm::min(s.map_min, p);
    s.map_max = glm::max(s.map_max, p);
  }
  ++s.map_points;
}

void extend(SceneSummary& s, const std::vector<glm::dvec3>& pts) {
  for (const glm::dvec3& p : pts) extend(s, p);
}

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
void append(std::string& out, const char* fmt, ...) {
  va_list args, again;
  va_start(args, fmt);
  va_copy(again, args);
  const int n = std::vsnprintf(nullptr, 0, fmt, args);
  va_end(args);
  if (n > 0) {
    const size_t at = out.size();
    out.resize(at + size_t(n) + 1);
    std::vsnprintf(out.data() + at, size_t(n) + 1, fmt, again);
    out.resize(at + size_t(n));
  }
  va_end(again);
}

// "28 (boundary 20, median 8)"; types with a zero count are left out.
template <size_t N, class E>
std::string by_type(size_t total, const std::array<size_t, N>& counts, const char* (*name_of)(E)) {
  std::string s = std::to_string(total);
  std::string parts;
  for (size_t i = 0; i < N; ++i) {
    if (!counts[i]) continue;
    if (!parts.empty()) parts += ", ";
    parts += std::string(name_of(static_cast<E>(i))) + " " + std::to_string(counts[i]);
  }
  if (!parts.empty()) s += " (" + parts + ")";
  return s;
}

}  // namespace

SceneSummary summarize(const Scene& scene) {
  SceneSummary s;
  s.provenance = scene.provenance;
  s.prompt = scene.prompt;
  const Map& m = scene.map;
  s.geo_reference = m.geo_reference;
  for (const RoadEdge& e : m.road_edges) count_type(s.road_edges_by_type, e.type), extend(s, e.points);
  for (const RoadLine& l : m.road_lines) count_type(s.road_lines_by_type, l.type), extend(s, l.points);
  for (const Lane& l : m.lanes) count_type(s.lanes_by_type, l.type), extend(s, l.points);
  for (const Polygon& p : m.crosswalks) extend(s, p.points);
  for (const Polygon& p : m.driveways) extend(s, p.points);
  for (const Polygon& p : m.speed_bumps) extend(s, p.points);
  for (const StopSign& st : m.stop_signs) extend(s, st.position);
  s.road_edges = m.road_edges.size();
  s.road_lines = m.road_lines.size();
  s.lanes = m.lanes.size();
  s.crosswalks = m.crosswalks.size();
  s.driveways = m.driveways.size();
  s.speed_bumps = m.speed_bumps.size();
  s.stop_signs = m.stop_signs.size();

  for (const Track& t : scene.tracks) {
    count_type(s.tracks_by_type, t.type);
    if (t.dynamic) count_type(s.dynamic_by_type, t.type);
    ++(t.dynamic ? s.dynamic_tracks : s.static_tracks);
    s.box_states += t.states.size();
    for (const BoxState& b : t.states) s.valid_box_states += b.valid ? 1 : 0;
  }
  s.tracks = scene.tracks.size();
  s.sdc_track_index = scene.sdc_track_index;

  s.timestamps = scene.timestamps.size();
  if (s.timestamps >= 2) s.duration = scene.timestamps.back() - scene.timestamps.front();
  s.current_time_index = scene.current_time_index;

  s.ego_poses = scene.ego.size();
  const EgoPose* prev = nullptr;
  for (const EgoPose& p : scene.ego) {
    if (!p.valid) continue;
    ++s.valid_ego_poses;
    if (prev) s.ego_path_length += glm::length(glm::dvec3(p.ego_to_world[3]) - glm::dvec3(prev->ego_to_world[3]));
    prev = &p;
  }

  for (const Camera& c : scene.cameras) s.camera_names.push_back(c.name);
  s.missing = scene.missing;
  return s;
}

std::string format_summary(const SceneSummary& s) {
  std::string out;
  const Provenance& p = s.provenance;
  append(out, "source: %s (%s%s%s)%s%s\n", p.source_file.empty() ? "-" : p.source_file.c_str(),
         p.source_format.empty() ? "unknown format" : p.source_format.c_str(), p.source_version.empty() ? "" : ", ",
         p.source_version.c_str(), p.scenario_id.empty() ? "" : ", scenario ", p.scenario_id.c_str());
  if (s.timestamps)
    append(out, "time: %zu timestamps over %.3f s, current index %d\n", s.timestamps, s.duration,
           s.current_time_index);
  else
    out += "time: none (static scene)\n";

  append(out, "map: %zu points", s.map_points);
  if (s.has_map_extent)
    append(out, ", x [%.3f, %.3f] y [%.3f, %.3f] z [%.3f, %.3f] m", s.map_min.x, s.map_max.x, s.map_min.y,
           s.map_max.y, s.map_min.z, s.map_max.z);
  out += '\n';
  append(out, "  road edges: %s\n", by_type(s.road_edges, s.road_edges_by_type, road_edge_type_name).c_str());
  append(out, "  road lines: %s\n", by_type(s.road_lines, s.road_lines_by_type, road_line_type_name).c_str());
  append(out, "  lanes: %s\n", by_type(s.lanes, s.lanes_by_type, lane_type_name).c_str());
  append(out, "  crosswalks: %zu, driveways: %zu, speed bumps: %zu, stop signs: %zu\n", s.crosswalks, s.driveways,
         s.speed_bumps, s.stop_signs);
  if (!s.geo_reference.empty()) append(out, "  geo reference: %s\n", s.geo_reference.c_str());

  append(out, "tracks: %s; static %zu, dynamic %zu", by_type(s.tracks, s.tracks_by_type, object_type_name).c_str(),
         s.static_tracks, s.dynamic_tracks);
  if (s.sdc_track_index >= 0) append(out, "; ego = track %d", s.sdc_track_index);
  out += '\n';
  if (s.tracks) append(out, "  boxes: %zu states, %zu valid\n", s.box_states, s.valid_box_states);

  if (s.ego_poses)
    append(out, "ego: %zu poses (%zu valid), path length %.3f m\n", s.ego_poses, s.valid_ego_poses,
           s.ego_path_length);
  else
    out += "ego: none\n";

  append(out, "cameras: %zu", s.camera_names.size());
  for (size_t i = 0; i < s.camera_names.size(); ++i)
    append(out, "%s%s", i ? ", " : " (", s.camera_names[i].c_str());
  out += s.camera_names.empty() ? "\n" : ")\n";

  if (!s.missing.empty()) {
    out += "missing: ";
    for (size_t i = 0; i < s.missing.size(); ++i) out += (i ? ", " : "") + s.missing[i];
    out += '\n';
  }
  if (!s.prompt.empty()) out += "prompt: " + s.prompt + '\n';
  return out;
}

}  // namespace icube::scene
