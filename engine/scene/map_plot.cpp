// Top-down scene plot: extent and layout, map layers, boxes, ego path and the
// overlays (title, legend, scale bar, +y arrow). See map_plot.h.
#include "scene/map_plot.h"

#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "scene/png_write.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <unordered_map>

namespace icube::scene {

namespace {

// ---- style ------------------------------------------------------------------------------

constexpr Rgba kRoadSurface{52, 57, 67, 255};
constexpr Rgba kBikeSurface{44, 70, 58, 255};
constexpr Rgba kLaneCentre{135, 150, 175, 120};
constexpr Rgba kBikeCentre{110, 200, 140, 150};
constexpr Rgba kWhite{240, 240, 240, 255};
constexpr Rgba kYellow{255, 196, 36, 255};
constexpr Rgba kCrosswalk{236, 236, 240, 255};
constexpr Rgba kSpeedBump{255, 138, 36, 255};
constexpr Rgba kDriveway{92, 130, 118, 255};
constexpr Rgba kStopSign{214, 34, 46, 255};
constexpr Rgba kPanel{12, 14, 18, 255};
constexpr Rgba kPanelBorder{66, 72, 86, 255};
constexpr Rgba kText{232, 234, 238, 255};
constexpr Rgba kTextDim{150, 158, 172, 255};
constexpr Rgba kHalo{10, 11, 14, 220};
constexpr Rgba kDark{14, 16, 20, 255};
constexpr Rgba kStartMarker{80, 220, 120, 255};
constexpr Rgba kEndMarker{255, 92, 72, 255};

constexpr double kDefaultLaneWidthM = 3.6;  // road surface around each lane centre when it cannot be estimated
constexpr double kEgoLengthM = 4.8, kEgoWidthM = 2.1;  // ego box when the ego has no track
constexpr int kPad = 12;                  // pixels kept free around the drawn extent
constexpr double kTrailSeconds = 2.0;     // past path drawn behind moving objects

Rgba lighten(Rgba c, double t) {
  auto mix = [&](uint8_t v) { return static_cast<uint8_t>(std::lround(v + (255 - v) * t)); };
  return {mix(c.r), mix(c.g), mix(c.b), c.a};
}

struct LineStyle {
  Rgba colour;
  bool twin = false;           // double line
  bool broken_a = false;       // the single line, or the +normal one of a pair
  bool broken_b = false;       // the -normal one of a pair
  double width_scale = 1.0;
};

LineStyle line_style(RoadLineType t) {
  switch (t) {
    case RoadLineType::BrokenSingleWhite: return {kWhite, false, true, false};
    case RoadLineType::SolidSingleWhite: return {kWhite, false, false, false};
    case RoadLineType::SolidDoubleWhite: return {kWhite, true, false, false};
    case RoadLineType::BrokenSingleYellow: return {kYellow, false, true, false};
    case RoadLineType::BrokenDoubleYellow: return {kYellow, true, true, true};
    case RoadLineType::SolidSingleYellow: return {kYellow, false, false, false};
    case RoadLineType::SolidDoubleYellow: return {kYellow, true, false, false};
    case RoadLineType::PassingDoubleYellow: return {kYellow, true, true, false};
    default: return {{150, 154, 166, 255}, false, false, false, 0.8};
  }
}

const char* line_label(RoadLineType t) {
  switch (t) {
    case RoadLineType::BrokenSingleWhite: return "white broken";
    case RoadLineType::SolidSingleWhite: return "white solid";
    case RoadLineType::SolidDoubleWhite: return "white double";
    case RoadLineType::BrokenSingleYellow: return "yellow broken";
    case RoadLineType::BrokenDoubleYellow: return "yellow double broken";
    case RoadLineType::SolidSingleYellow: return "yellow solid";
    case RoadLineType::SolidDoubleYellow: return "yellow double";
    case RoadLineType::PassingDoubleYellow: return "yellow passing";
    default: return "line (type unknown)";
  }
}

// Pixel sizes derived from the scale, with floors so features kilometres
// away stay visible and ceilings so a zoomed-in plot stays legible.
struct Metrics {
  double s = 1.0;  // pixels per metre
  double edge_w = 2.0, line_w = 1.2, line_sep = 3.0, dash = 6.0, gap = 8.0, centre_w = 1.0, surface_w = 2.0;
  double path_w = 3.0, stop_r = 5.0, stripe_period = 4.0, trail_w = 1.5;
  int ts = 2;  // text scale

  Metrics(double px_per_m, int text_scale, double lane_width_m) : s(px_per_m), ts(text_scale) {
    edge_w = std::clamp(0.30 * s, 1.6, 4.5);
    line_w = std::clamp(0.15 * s, 1.1, 3.0);
    line_sep = std::max(0.30 * s, line_w * 2.2);
    dash = std::max(3.0 * s, 4.0);
    gap = std::max(6.0 * s, 4.0);
    centre_w = std::clamp(0.08 * s, 0.8, 1.6);
    surface_w = std::max(lane_width_m * s + 1.0, 1.5);  // +1 px: neighbours' soft edges overlap, no seam
    path_w = std::clamp(0.6 * s, 3.0, 6.0);
    stop_r = std::clamp(0.9 * s, 4.5, 12.0);
    stripe_period = std::max(1.2 * s, 4.0);
    trail_w = std::clamp(0.25 * s, 1.2, 3.0);
  }
};

// ---- extent -------------------------------------------------------------------------------

struct Extent {
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  void add(double x, double y) {
    x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
  }
  bool empty() const { return !(x0 <= x1 && y0 <= y1); }
};

std::string source_name(const Scene& scene) {
  return scene.provenance.source_file.empty() ? std::string("scene") : scene.provenance.source_file;
}

void require_finite(const Scene& scene, bool ok, const std::string& where) {
  if (!ok) throw InputError(source_name(scene), where, "coordinate is not finite");
}

bool finite3(const glm::dvec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

template <class Feature>
void check_points(const Scene& scene, const std::vector<Feature>& features, const char* layer) {
  for (size_t i = 0; i < features.size(); ++i)
    for (size_t j = 0; j < features[i].points.size(); ++j)
      if (!finite3(features[i].points[j]))
        require_finite(scene, false,
                       std::string("map.") + layer + "[" + std::to_string(i) + "].points[" + std::to_string(j) + "]");
}

// Everything the plot reads must be finite: a NaN would silently vanish or
// stretch the extent to infinity.
void check_finite(const Scene& scene) {
  const Map& m = scene.map;
  check_points(scene, m.road_edges, "road_edges");
  check_points(scene, m.road_lines, "road_lines");
  check_points(scene, m.lanes, "lanes");
  check_points(scene, m.crosswalks, "crosswalks");
  check_points(scene, m.driveways, "driveways");
  check_points(scene, m.speed_bumps, "speed_bumps");
  for (size_t i = 0; i < m.stop_signs.size(); ++i)
    require_finite(scene, finite3(m.stop_signs[i].position), "map.stop_signs[" + std::to_string(i) + "].position");
  for (size_t i = 0; i < scene.tracks.size(); ++i)
    for (size_t j = 0; j < scene.tracks[i].states.size(); ++j) {
      const BoxState& b = scene.tracks[i].states[j];
      if (!b.valid) continue;
      require_finite(scene,
                     finite3(b.center) && std::isfinite(b.length) && std::isfinite(b.width) && std::isfinite(b.heading),
                     "tracks[" + std::to_string(i) + "].states[" + std::to_string(j) + "]");
    }
  for (size_t i = 0; i < scene.ego.size(); ++i) {
    if (!scene.ego[i].valid) continue;
    bool ok = true;
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) ok = ok && std::isfinite(scene.ego[i].ego_to_world[c][r]);
    require_finite(scene, ok, "ego[" + std::to_string(i) + "].ego_to_world");
  }
}

bool map_has_content(const Map& m) {
  auto any = [](const auto& features) {
    for (const auto& f : features)
      if (!f.points.empty()) return true;
    return false;
  };
  return any(m.road_edges) || any(m.road_lines) || any(m.lanes) || any(m.crosswalks) || any(m.driveways) ||
         any(m.speed_bumps) || !m.stop_signs.empty();
}

// ---- the objects at one time ------------------------------------------------------------------

struct PlacedBox {
  glm::dvec3 centre{0.0};
  double length = 0.0, width = 0.0, heading = 0.0;
  ObjectType type = ObjectType::Unset;
  bool dynamic = false;
  size_t track = 0;
};

std::vector<PlacedBox> boxes_at(const Scene& scene, int t) {
  std::vector<PlacedBox> out;
  if (t < 0) return out;
  for (size_t i = 0; i < scene.tracks.size(); ++i) {
    const Track& tr = scene.tracks[i];
    if (static_cast<size_t>(t) >= tr.states.size() || !tr.states[static_cast<size_t>(t)].valid) continue;
    const BoxState& b = tr.states[static_cast<size_t>(t)];
    out.push_back({b.center, std::abs(b.length), std::abs(b.width), b.heading, tr.type, tr.dynamic, i});
  }
  return out;
}

// The ego box at time t: the SDC track's box, else a car-sized box at the ego
// pose. False when there is none.
bool ego_box_at(const Scene& scene, int t, PlacedBox& out) {
  if (t < 0) return false;
  const size_t k = static_cast<size_t>(t);
  if (scene.sdc_track_index >= 0 && static_cast<size_t>(scene.sdc_track_index) < scene.tracks.size()) {
    const Track& tr = scene.tracks[static_cast<size_t>(scene.sdc_track_index)];
    if (k < tr.states.size() && tr.states[k].valid) {
      const BoxState& b = tr.states[k];
      out = {b.center, std::abs(b.length), std::abs(b.width), b.heading, tr.type, tr.dynamic,
             static_cast<size_t>(scene.sdc_track_index)};
      return true;
    }
  }
  if (k < scene.ego.size() && scene.ego[k].valid) {
    const glm::dmat4& m = scene.ego[k].ego_to_world;
    out = {glm::dvec3(m[3]), kEgoLengthM, kEgoWidthM, std::atan2(m[0].y, m[0].x), ObjectType::Vehicle, true,
           static_cast<size_t>(-1)};
    return true;
  }
  return false;
}

std::vector<glm::dvec3> ego_path(const Scene& scene) {
  std::vector<glm::dvec3> path;
  for (const EgoPose& e : scene.ego)
    if (e.valid) path.emplace_back(e.ego_to_world[3]);
  if (path.empty() && scene.sdc_track_index >= 0 && static_cast<size_t>(scene.sdc_track_index) < scene.tracks.size())
    for (const BoxState& b : scene.tracks[static_cast<size_t>(scene.sdc_track_index)].states)
      if (b.valid) path.push_back(b.center);
  return path;
}

double path_length(const std::vector<glm::dvec3>& path) {
  double len = 0.0;
  for (size_t i = 1; i < path.size(); ++i) len += glm::length(glm::dvec2(path[i] - path[i - 1]));
  return len;
}

// The map's lane width for the road surface: the 85th percentile, over
// lanes, of the smallest lateral distance from a lane's midpoint to a
// parallel lane centre 2-6 m away, at least 3.6 m. The surface is drawn that
// wide around every centre line, so adjacent lanes meet without gaps.
double estimate_lane_width(const Map& map) {
  struct Sample {
    glm::dvec2 p, dir;
    size_t lane;
  };
  constexpr double kCell = 6.0, kMin = 2.0, kMax = 6.0;
  auto cell_key = [](glm::dvec2 p) {
    return (static_cast<uint64_t>(static_cast<int64_t>(std::floor(p.x / kCell))) * 0x9E3779B97F4A7C15ull) ^
           static_cast<uint64_t>(static_cast<int64_t>(std::floor(p.y / kCell)));
  };
  std::vector<Sample> samples;
  std::vector<size_t> mid;  // index of each lane's middle sample
  for (size_t i = 0; i < map.lanes.size(); ++i) {
    const auto& pts = map.lanes[i].points;
    const size_t first = samples.size();
    for (size_t k = 1; k < pts.size(); ++k) {
      const glm::dvec2 a(pts[k - 1]), b(pts[k]);
      const double len = glm::length(b - a);
      if (len < 1e-6) continue;
      if (samples.size() > first && glm::length(a - samples.back().p) < 1.0) continue;  // about one per metre
      samples.push_back({a, (b - a) / len, i});
    }
    if (samples.size() > first) mid.push_back(first + (samples.size() - first) / 2);
  }
  std::unordered_multimap<uint64_t, size_t> grid;
  for (size_t j = 0; j < samples.size(); ++j) grid.emplace(cell_key(samples[j].p), j);
  std::vector<double> widths;
  for (size_t m : mid) {
    const Sample& a = samples[m];
    double best = kMax;
    for (int ox = -1; ox <= 1; ++ox)
      for (int oy = -1; oy <= 1; ++oy) {
        auto [lo, hi] = grid.equal_range(cell_key(a.p + glm::dvec2(ox * kCell, oy * kCell)));
        for (auto it = lo; it != hi; ++it) {
          const Sample& b = samples[it->second];
          if (b.lane == a.lane || std::abs(glm::dot(a.dir, b.dir)) < 0.97) continue;
          const glm::dvec2 d = b.p - a.p;
          const double along = glm::dot(d, a.dir), across = std::abs(a.dir.x * d.y - a.dir.y * d.x);
          if (std::abs(along) < 1.0 && across >= kMin && across < best) best = across;
        }
      }
    if (best < kMax) widths.push_back(best);
  }
  if (widths.size() < 3) return kDefaultLaneWidthM;
  // A high percentile: merging and junction lanes run closer than the lane
  // width, and a surface narrower than the spacing would leave dark gaps.
  const size_t k = widths.size() * 85 / 100;
  std::nth_element(widths.begin(), widths.begin() + static_cast<long>(k), widths.end());
  return std::clamp(widths[k], kDefaultLaneWidthM, 5.5);
}

// ---- drawing helpers (pixel space) ------------------------------------------------------------

std::vector<glm::dvec2> project(const MapView& v, const std::vector<glm::dvec3>& pts) {
  std::vector<glm::dvec2> out;
  out.reserve(pts.size());
  for (const glm::dvec3& p : pts) out.push_back(v.to_pixel(p.x, p.y));
  return thin_polyline(out, 0.5);
}

void stroke_maybe_dashed(CoverageMask& m, const std::vector<glm::dvec2>& pts, double w, bool broken, double dash,
                         double gap) {
  if (!broken) {
    m.stroke_polyline(pts, w);
    return;
  }
  for (const auto& piece : dash_polyline(pts, dash, gap)) m.stroke_polyline(piece, w);
}

void draw_road_line(Canvas& c, const std::vector<glm::dvec2>& pts, RoadLineType type, double w, double sep,
                    double dash, double gap) {
  const LineStyle st = line_style(type);
  CoverageMask& m = c.scratch();
  w *= st.width_scale;
  if (st.twin) {
    stroke_maybe_dashed(m, offset_polyline(pts, sep * 0.5), w, st.broken_a, dash, gap);
    stroke_maybe_dashed(m, offset_polyline(pts, -sep * 0.5), w, st.broken_b, dash, gap);
  } else {
    stroke_maybe_dashed(m, pts, w, st.broken_a, dash, gap);
  }
  c.composite(m, st.colour);
}

// Direction of the longest edge of a ring (zebra stripes vary along it).
glm::dvec2 long_axis(const std::vector<glm::dvec2>& ring) {
  glm::dvec2 best(1.0, 0.0);
  double best_len = 0.0;
  for (size_t i = 0; i < ring.size(); ++i) {
    const glm::dvec2 d = ring[(i + 1) % ring.size()] - ring[i];
    const double len = glm::length(d);
    if (len > best_len) best_len = len, best = d / len;
  }
  return best;
}

void draw_crosswalk(Canvas& c, const std::vector<glm::dvec2>& ring, double period) {
  c.fill_polygon(ring, with_opacity(kCrosswalk, 0.16));
  CoverageMask& m = c.scratch();
  m.fill_polygon(ring);
  m.modulate_stripes(ring.empty() ? glm::dvec2(0.0) : ring[0], long_axis(ring), period, 0.5);
  c.composite(m, with_opacity(kCrosswalk, 0.78));
  c.stroke_polyline(ring, 1.0, with_opacity(kCrosswalk, 0.45), true);
}

void draw_speed_bump(Canvas& c, const std::vector<glm::dvec2>& ring, double period) {
  c.fill_polygon(ring, with_opacity(kSpeedBump, 0.35));
  CoverageMask& m = c.scratch();
  m.fill_polygon(ring);
  const glm::dvec2 a = long_axis(ring);
  m.modulate_stripes(ring.empty() ? glm::dvec2(0.0) : ring[0], glm::normalize(a + glm::dvec2(-a.y, a.x)),
                     period * 0.8, 0.5);
  c.composite(m, with_opacity(kSpeedBump, 0.9));
  c.stroke_polyline(ring, 1.2, kSpeedBump, true);
}

void draw_driveway(Canvas& c, const std::vector<glm::dvec2>& ring) {
  c.fill_polygon(ring, with_opacity(kDriveway, 0.45));
  c.stroke_polyline(ring, 1.0, with_opacity(lighten(kDriveway, 0.3), 0.8), true);
}

std::vector<glm::dvec2> octagon(glm::dvec2 centre, double r) {
  std::vector<glm::dvec2> ring;
  for (int i = 0; i < 8; ++i) {
    const double a = std::numbers::pi / 8.0 + i * std::numbers::pi / 4.0;
    ring.push_back(centre + r * glm::dvec2(std::cos(a), std::sin(a)));
  }
  return ring;
}

void draw_stop_sign(Canvas& c, glm::dvec2 centre, double r) {
  c.fill_polygon(octagon(centre, r + 1.2), kWhite);
  c.fill_polygon(octagon(centre, r), kStopSign);
}

// World heading -> pixel direction (y down).
glm::dvec2 pixel_dir(double heading) { return {std::cos(heading), -std::sin(heading)}; }

std::vector<glm::dvec2> box_ring(glm::dvec2 centre, double heading, double len, double wid) {
  const glm::dvec2 f = pixel_dir(heading), l(f.y, -f.x);  // l: world left in pixels
  return {centre + f * (len / 2) + l * (wid / 2), centre + f * (len / 2) - l * (wid / 2),
          centre - f * (len / 2) - l * (wid / 2), centre - f * (len / 2) + l * (wid / 2)};
}

enum class BoxLook { Static, Dynamic, Ego };

void draw_box(Canvas& c, glm::dvec2 centre, double heading, double len_px, double wid_px, Rgba colour, BoxLook look) {
  len_px = std::max(len_px, 3.0), wid_px = std::max(wid_px, 2.0);
  const std::vector<glm::dvec2> ring = box_ring(centre, heading, len_px, wid_px);
  const glm::dvec2 f = pixel_dir(heading);
  const glm::dvec2 nose = centre + f * (len_px / 2 + std::max(2.0, 0.18 * len_px));
  const double tick_w = std::clamp(0.14 * wid_px, 1.2, 3.0);
  switch (look) {
    case BoxLook::Static:
      c.fill_polygon(ring, with_opacity(colour, 0.28));
      c.stroke_polyline(ring, std::clamp(0.08 * wid_px, 1.2, 2.0), colour, true);
      c.stroke_polyline({centre, nose}, tick_w, colour);
      break;
    case BoxLook::Dynamic:
      c.fill_polygon(ring, with_opacity(colour, 0.92));
      c.stroke_polyline(ring, std::clamp(0.08 * wid_px, 1.0, 2.0), lighten(colour, 0.55), true);
      c.stroke_polyline({centre, nose}, tick_w, kDark);
      break;
    case BoxLook::Ego:
      c.fill_polygon(ring, colour);
      c.stroke_polyline(ring, std::clamp(0.12 * wid_px, 1.5, 3.0), kWhite, true);
      c.stroke_polyline({centre, nose}, tick_w, kWhite);
      break;
  }
}

void draw_marker(Canvas& c, glm::dvec2 p, double r, Rgba fill) {
  c.fill_circle(p, r + 1.5, kDark);
  c.fill_circle(p, r, fill);
}

// ---- legend ---------------------------------------------------------------------------------

enum class Swatch { Lanes, BikeLanes, Edge, Line, Crosswalk, SpeedBump, Driveway, StopSign, Box, Ego, Path };

struct LegendItem {
  std::string label;
  Swatch swatch;
  Rgba colour{};
  RoadLineType line = RoadLineType::Unknown;
  BoxLook look = BoxLook::Static;
};

void draw_swatch(Canvas& c, const LegendItem& it, double x, double y, double w, double h, const Metrics& mt) {
  const double cy = y + h / 2;
  const std::vector<glm::dvec2> mid{{x, cy}, {x + w, cy}};
  const std::vector<glm::dvec2> rect{{x, y}, {x + w, y}, {x + w, y + h}, {x, y + h}};
  switch (it.swatch) {
    case Swatch::Lanes:
    case Swatch::BikeLanes:
      c.fill_rect(x, y + 1, x + w, y + h - 1, it.swatch == Swatch::Lanes ? kRoadSurface : kBikeSurface);
      c.stroke_polyline(mid, 1.0, it.swatch == Swatch::Lanes ? kLaneCentre : kBikeCentre);
      break;
    case Swatch::Edge: c.stroke_polyline(mid, 3.0, it.colour); break;
    case Swatch::Line:
      c.fill_rect(x, y + 1, x + w, y + h - 1, kRoadSurface);
      draw_road_line(c, mid, it.line, 1.6, 4.4, 7.0, 5.0);
      break;
    case Swatch::Crosswalk: draw_crosswalk(c, rect, std::max(4.0, h / 3)); break;
    case Swatch::SpeedBump: draw_speed_bump(c, rect, std::max(4.0, h / 3)); break;
    case Swatch::Driveway: draw_driveway(c, rect); break;
    case Swatch::StopSign: draw_stop_sign(c, {x + w / 2, cy}, std::min(h / 2 - 1.5, 7.0)); break;
    case Swatch::Box: draw_box(c, {x + w / 2, cy}, 0.0, w * 0.62, h * 0.62, it.colour, it.look); break;
    case Swatch::Ego: draw_box(c, {x + w / 2, cy}, 0.0, w * 0.62, h * 0.62, kEgoColour, BoxLook::Ego); break;
    case Swatch::Path:
      c.stroke_polyline(mid, mt.path_w + 3, with_opacity(kDark, 0.8));
      c.stroke_polyline(mid, std::min(mt.path_w, 4.0), kEgoPathColour);
      draw_marker(c, mid[0], 3.5, kStartMarker);
      draw_marker(c, mid[1], 3.5, kEndMarker);
      break;
  }
}

template <class Feature, class TypeOf>
std::vector<std::pair<int, int>> type_counts(const std::vector<Feature>& features, TypeOf type_of) {
  std::vector<std::pair<int, int>> counts;  // (type, count), in type order
  for (const Feature& f : features) {
    if (f.points.empty()) continue;
    const int t = static_cast<int>(type_of(f));
    auto it = std::find_if(counts.begin(), counts.end(), [&](const auto& p) { return p.first == t; });
    if (it == counts.end())
      counts.emplace_back(t, 1);
    else
      ++it->second;
  }
  std::sort(counts.begin(), counts.end());
  return counts;
}

template <class Feature>
size_t non_empty(const std::vector<Feature>& features) {
  return static_cast<size_t>(std::count_if(features.begin(), features.end(), [](const Feature& f) { return !f.points.empty(); }));
}

std::string counted(const std::string& label, size_t n) { return label + " (" + std::to_string(n) + ")"; }

std::vector<LegendItem> legend_items(const Scene& scene, const MapPlotOptions& opt, const std::vector<PlacedBox>& boxes, bool has_ego_box, double ego_len) {
  const Map& m = scene.map;
  std::vector<LegendItem> items;
  size_t bike = 0, other = 0;
  for (const Lane& l : m.lanes)
    if (!l.points.empty()) (l.type == LaneType::BikeLane ? bike : other) += 1;
  if (other) items.push_back({counted("lanes", other), Swatch::Lanes});
  if (bike) items.push_back({counted("bike lanes", bike), Swatch::BikeLanes});
  for (auto [type, n] : type_counts(m.road_edges, [](const RoadEdge& e) { return e.type; })) {
    const auto et = static_cast<RoadEdgeType>(type);
    items.push_back({counted(std::string("road edge: ") + road_edge_type_name(et), static_cast<size_t>(n)),
                     Swatch::Edge, road_edge_colour(et)});
  }
  for (auto [type, n] : type_counts(m.road_lines, [](const RoadLine& l) { return l.type; })) {
    const auto lt = static_cast<RoadLineType>(type);
    items.push_back({counted(line_label(lt), static_cast<size_t>(n)), Swatch::Line, {}, lt});
  }
  if (size_t n = non_empty(m.crosswalks)) items.push_back({counted("crosswalks", n), Swatch::Crosswalk});
  if (size_t n = non_empty(m.speed_bumps)) items.push_back({counted("speed bumps", n), Swatch::SpeedBump});
  if (size_t n = non_empty(m.driveways)) items.push_back({counted("driveways", n), Swatch::Driveway});
  if (!m.stop_signs.empty()) items.push_back({counted("stop signs", m.stop_signs.size()), Swatch::StopSign});
  if (opt.boxes) {
    for (ObjectType ot : {ObjectType::Vehicle, ObjectType::Pedestrian, ObjectType::Cyclist, ObjectType::Sign,
                          ObjectType::Other, ObjectType::Unset})
      for (bool dyn : {true, false}) {
        size_t n = 0;
        for (const PlacedBox& b : boxes)
          if (b.type == ot && b.dynamic == dyn && static_cast<int>(b.track) != scene.sdc_track_index) ++n;
        if (!n) continue;
        std::string label = std::string(object_type_name(ot)) + (dyn ? ", moving" : ", static");
        items.push_back({counted(label, n), Swatch::Box, object_colour(ot), RoadLineType::Unknown,
                         dyn ? BoxLook::Dynamic : BoxLook::Static});
      }
    if (has_ego_box) items.push_back({"ego", Swatch::Ego});
  }
  if (opt.ego_path && ego_len > 0.0) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "ego path (%.0f m)", ego_len);
    items.push_back({ego_len < 1.0 ? std::string("ego path (stationary)") : std::string(buf), Swatch::Path});
  }
  return items;
}

// ---- text -----------------------------------------------------------------------------------

std::string fmt_g(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string metres_label(double m) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.0f m", m);
  return buf;
}

std::string time_label(const Scene& scene, int t) {
  if (t < 0) return "map only (no timestamps)";
  char buf[96];
  std::snprintf(buf, sizeof buf, "t = %.2f s (frame %d of 0-%zu)", scene.timestamps[static_cast<size_t>(t)], t,
                scene.timestamps.size() - 1);
  return buf;
}

}  // namespace

// ---- public helpers -----------------------------------------------------------------------------

Rgba road_edge_colour(RoadEdgeType type) {
  switch (type) {
    case RoadEdgeType::Boundary: return {226, 230, 238, 255};
    case RoadEdgeType::Median: return {186, 150, 255, 255};
    case RoadEdgeType::Curb: return {132, 196, 255, 255};
    default: return {176, 180, 190, 255};
  }
}

Rgba road_line_colour(RoadLineType type) { return line_style(type).colour; }

Rgba object_colour(ObjectType type) {
  switch (type) {
    case ObjectType::Vehicle: return {74, 158, 255, 255};
    case ObjectType::Pedestrian: return {255, 122, 72, 255};
    case ObjectType::Cyclist: return {96, 222, 122, 255};
    case ObjectType::Sign: return {236, 216, 80, 255};
    default: return {186, 186, 198, 255};
  }
}

double round_scale_length(double max_metres) {
  if (!(max_metres >= 1.0) || !std::isfinite(max_metres)) return 1.0;
  double p = std::pow(10.0, std::floor(std::log10(max_metres)));
  double best = p;
  for (double k : {1.0, 2.0, 5.0, 10.0})
    if (k * p <= max_metres * (1.0 + 1e-12)) best = k * p;
  return best;
}

int plot_time_index(const Scene& scene, const MapPlotOptions& options) {
  const std::string file = source_name(scene);
  const size_t n = scene.timestamps.size();
  if (n == 0) {
    if (options.time || options.time_index)
      throw InputError(file, "", "the scene has no timestamps, so no time can be chosen");
    return -1;
  }
  if (options.time_index) {
    const int i = *options.time_index;
    if (i < 0 || static_cast<size_t>(i) >= n)
      throw InputError(file, "", "frame " + std::to_string(i) + " is outside the scene (0 to " + std::to_string(n - 1) + ")");
    return i;
  }
  if (options.time) {
    const double t = *options.time;
    const auto& ts = scene.timestamps;
    const double half = n > 1 ? 0.5 * (ts.back() - ts.front()) / static_cast<double>(n - 1) : 0.05;
    if (!std::isfinite(t) || t < ts.front() - half || t > ts.back() + half)
      throw InputError(file, "", "time " + fmt_g(t) + " s is outside the scene (" + fmt_g(ts.front()) + " to " +
                                     fmt_g(ts.back()) + " s)");
    size_t best = 0;
    for (size_t i = 1; i < n; ++i)
      if (std::abs(ts[i] - t) < std::abs(ts[best] - t)) best = i;
    return static_cast<int>(best);
  }
  return std::clamp(scene.current_time_index, 0, static_cast<int>(n - 1));
}

// ---- render -------------------------------------------------------------------------------------

MapPlot render_map(const Scene& scene, const MapPlotOptions& opt) {
  const std::string file = source_name(scene);
  if (opt.width < 320 || opt.width > 16384)
    throw std::invalid_argument("plot: width " + std::to_string(opt.width) + " is out of range (320 to 16384)");
  if (opt.max_height < 240 || opt.max_height > 16384)
    throw std::invalid_argument("plot: max height " + std::to_string(opt.max_height) + " is out of range (240 to 16384)");
  if (!std::isfinite(opt.margin_m) || opt.margin_m < 0.0)
    throw std::invalid_argument("plot: margin must be a finite number of metres >= 0");
  check_finite(scene);
  const int t = plot_time_index(scene, opt);
  const Map& map = scene.map;

  const std::vector<PlacedBox> boxes = opt.boxes ? boxes_at(scene, t) : std::vector<PlacedBox>{};
  PlacedBox ego_box;
  const bool has_ego_box = opt.boxes && ego_box_at(scene, t, ego_box);
  const std::vector<glm::dvec3> path = opt.ego_path ? ego_path(scene) : std::vector<glm::dvec3>{};
  if (!map_has_content(map) && boxes.empty() && !has_ego_box && path.empty())
    throw InputError(file, "", "nothing to plot: the scene has no map features, object boxes or ego poses");

  // World extent.
  Extent ext;
  if (opt.bounds) {
    const PlotBounds& b = *opt.bounds;
    if (!(std::isfinite(b.min_x) && std::isfinite(b.min_y) && std::isfinite(b.max_x) && std::isfinite(b.max_y)) ||
        !(b.max_x > b.min_x) || !(b.max_y > b.min_y))
      throw std::invalid_argument("plot: bounds need finite min < max in x and y");
    ext.add(b.min_x, b.min_y), ext.add(b.max_x, b.max_y);
  } else {
    auto add_all = [&](const auto& features) {
      for (const auto& f : features)
        for (const glm::dvec3& p : f.points) ext.add(p.x, p.y);
    };
    add_all(map.road_edges), add_all(map.road_lines), add_all(map.lanes), add_all(map.crosswalks);
    add_all(map.driveways), add_all(map.speed_bumps);
    for (const StopSign& s : map.stop_signs) ext.add(s.position.x, s.position.y);
    for (const PlacedBox& b : boxes) {
      const double r = 0.5 * std::hypot(b.length, b.width);
      ext.add(b.centre.x - r, b.centre.y - r), ext.add(b.centre.x + r, b.centre.y + r);
    }
    if (has_ego_box) ext.add(ego_box.centre.x, ego_box.centre.y);
    for (const glm::dvec3& p : path) ext.add(p.x, p.y);
    // A single point or a line still gets an area (at least 20 m across).
    const double cx = 0.5 * (ext.x0 + ext.x1), cy = 0.5 * (ext.y0 + ext.y1);
    const double hx = std::max(0.5 * (ext.x1 - ext.x0), 10.0), hy = std::max(0.5 * (ext.y1 - ext.y0), 10.0);
    ext = Extent{};
    ext.add(cx - hx - opt.margin_m, cy - hy - opt.margin_m), ext.add(cx + hx + opt.margin_m, cy + hy + opt.margin_m);
  }
  const double dx = ext.x1 - ext.x0, dy = ext.y1 - ext.y0;

  // Bands: title (with the +y arrow at its right) above the map; legend and
  // scale bar below it, so nothing covers the map.
  const int W = opt.width;
  const int ts = std::max(1, static_cast<int>(std::lround(W / 800.0)));
  const int title_scale = W >= 1200 ? ts + 1 : ts;
  const int title_h = 12 + 9 * title_scale + 8 + 9 * ts + 12;
  const std::vector<LegendItem> items =
      opt.legend ? legend_items(scene, opt, boxes, has_ego_box, path.size() >= 2 ? path_length(path) : 0.0)
                 : std::vector<LegendItem>{};
  const int sw = 26 * ts, sh = 8 * ts + 2, row_h = sh + 6 * ts, col_gap = 16 * ts;
  const double bar_max_px = 0.22 * (W - 2.0 * kPad);
  const int scale_block_w = opt.scale_bar ? static_cast<int>(bar_max_px) + text_width("00000 m", ts) + 2 * kPad : 0;
  const int scale_block_h = opt.scale_bar ? 3 * ts + 2 + 6 + 10 * ts : 0;
  int col_w = 0;
  for (const LegendItem& it : items) col_w = std::max(col_w, sw + 6 * ts + text_width(it.label, ts));
  col_w += col_gap;
  const int legend_w = std::max(W - 2 * kPad - scale_block_w, col_w);
  const int ncols = items.empty() ? 1 : std::max(1, legend_w / std::max(col_w, 1));
  const int nrows =
      items.empty() ? 0 : static_cast<int>((items.size() + static_cast<size_t>(ncols) - 1) / static_cast<size_t>(ncols));
  const int footer_h = items.empty() && !opt.scale_bar ? 0 : std::max(nrows * row_h, scale_block_h) + 2 * kPad;

  // Map area: uniform scale to the width, unless that makes it too tall.
  const int min_map_h = 240;
  const int max_map_h = std::max(min_map_h, opt.max_height - title_h - footer_h);
  double s = (W - 2.0 * kPad) / dx;
  int map_h = static_cast<int>(std::ceil(dy * s)) + 2 * kPad;
  if (map_h > max_map_h) {
    s = (max_map_h - 2.0 * kPad) / dy;
    map_h = max_map_h;
  }
  map_h = std::max(map_h, min_map_h);
  const int H = title_h + map_h + footer_h;

  MapView view;
  view.pixels_per_metre = s;
  view.map_x0 = 0, view.map_y0 = title_h, view.map_width = W, view.map_height = map_h;
  // Centre the extent in the map area.
  view.world_min_x = 0.5 * (ext.x0 + ext.x1) - 0.5 * W / s;
  view.world_max_y = 0.5 * (ext.y0 + ext.y1) + 0.5 * map_h / s;

  MapPlot out{Canvas(W, H, kPlotBackground), view, t, 0.0, estimate_lane_width(map), {}, {}};
  Canvas& c = out.image;
  const Metrics mt(s, ts, out.lane_width_m);

  // ---- map layers, bottom to top ----
  for (const Polygon& p : map.driveways)
    if (p.points.size() >= 3) draw_driveway(c, project(view, p.points));
  {
    CoverageMask& m = c.scratch();
    for (const Lane& l : map.lanes)
      if (l.type != LaneType::BikeLane) m.stroke_polyline(project(view, l.points), mt.surface_w);
    c.composite(m, kRoadSurface);
    for (const Lane& l : map.lanes)
      if (l.type == LaneType::BikeLane) m.stroke_polyline(project(view, l.points), std::max(1.5 * s, 1.5));
    c.composite(m, kBikeSurface);
  }
  for (const Polygon& p : map.crosswalks)
    if (p.points.size() >= 3) draw_crosswalk(c, project(view, p.points), mt.stripe_period);
  for (const Polygon& p : map.speed_bumps)
    if (p.points.size() >= 3) draw_speed_bump(c, project(view, p.points), mt.stripe_period);
  {
    CoverageMask& m = c.scratch();
    for (const Lane& l : map.lanes)
      if (l.type != LaneType::BikeLane) m.stroke_polyline(project(view, l.points), mt.centre_w);
    c.composite(m, kLaneCentre);
    for (const Lane& l : map.lanes)
      if (l.type == LaneType::BikeLane) m.stroke_polyline(project(view, l.points), mt.centre_w);
    c.composite(m, kBikeCentre);
  }
  for (const RoadLine& l : map.road_lines)
    if (l.points.size() >= 2) draw_road_line(c, project(view, l.points), l.type, mt.line_w, mt.line_sep, mt.dash, mt.gap);
  for (RoadEdgeType et : {RoadEdgeType::Unknown, RoadEdgeType::Boundary, RoadEdgeType::Median, RoadEdgeType::Curb}) {
    CoverageMask& m = c.scratch();
    for (const RoadEdge& e : map.road_edges)
      if (e.type == et) m.stroke_polyline(project(view, e.points), mt.edge_w);
    c.composite(m, road_edge_colour(et));
  }
  for (const StopSign& st : map.stop_signs) draw_stop_sign(c, view.to_pixel(st.position.x, st.position.y), mt.stop_r);

  // ---- objects, ego path, ego ----
  if (opt.boxes && t >= 0) {
    // Trails behind moving objects: their last kTrailSeconds up to t.
    for (const PlacedBox& b : boxes) {
      if (!b.dynamic || static_cast<int>(b.track) == scene.sdc_track_index) continue;
      std::vector<glm::dvec3> trail;
      const Track& tr = scene.tracks[b.track];
      for (int k = t; k >= 0; --k) {
        if (scene.timestamps[static_cast<size_t>(t)] - scene.timestamps[static_cast<size_t>(k)] > kTrailSeconds) break;
        if (static_cast<size_t>(k) < tr.states.size() && tr.states[static_cast<size_t>(k)].valid)
          trail.push_back(tr.states[static_cast<size_t>(k)].center);
      }
      if (trail.size() >= 2) c.stroke_polyline(project(view, trail), mt.trail_w, with_opacity(object_colour(b.type), 0.45));
    }
  }
  if (opt.ego_path && path.size() >= 2 && path_length(path) >= 1.0) {
    const std::vector<glm::dvec2> pp = project(view, path);
    c.stroke_polyline(pp, mt.path_w + 3.0, with_opacity(kDark, 0.75));
    c.stroke_polyline(pp, mt.path_w, kEgoPathColour);
    const double r = std::max(4.0, mt.path_w * 1.1);
    draw_marker(c, pp.front(), r, kStartMarker);
    draw_marker(c, pp.back(), r, kEndMarker);
    auto label = [&](glm::dvec2 at, const char* text, Rgba colour) {
      if (at.x < -100 || at.y < -100 || at.x > W + 100 || at.y > H + 100) return;  // off the picture
      c.draw_text(static_cast<int>(at.x + r + 4), static_cast<int>(at.y - 4 * ts), text, colour, ts, kHalo);
    };
    label(pp.front(), "start", kStartMarker);
    label(pp.back(), "end", kEndMarker);
  }
  if (opt.boxes) {
    for (int pass = 0; pass < 2; ++pass)  // static under moving
      for (const PlacedBox& b : boxes) {
        if (b.dynamic != (pass == 1) || static_cast<int>(b.track) == scene.sdc_track_index) continue;
        draw_box(c, view.to_pixel(b.centre.x, b.centre.y), b.heading, b.length * s, b.width * s, object_colour(b.type),
                 b.dynamic ? BoxLook::Dynamic : BoxLook::Static);
      }
    if (has_ego_box) {
      const glm::dvec2 e = view.to_pixel(ego_box.centre.x, ego_box.centre.y);
      c.fill_circle(e, std::max(ego_box.length * s * 0.9, 10.0), with_opacity(kEgoColour, 0.2));
      draw_box(c, view.to_pixel(ego_box.centre.x, ego_box.centre.y), ego_box.heading, std::max(ego_box.length * s, 8.0),
               std::max(ego_box.width * s, 4.0), kEgoColour, BoxLook::Ego);
    }
  }

  // ---- overlays: title band, footer band (legend, scale bar) ----
  c.fill_rect(0, 0, W, title_h, kPanel);
  c.fill_rect(0, title_h - 1, W, title_h, kPanelBorder);
  {
    const Provenance& pv = scene.provenance;
    std::string line1 = pv.source_file.empty() ? std::string("(unnamed scene)")
                                               : std::filesystem::path(pv.source_file).filename().string();
    if (!pv.scenario_id.empty()) line1 += "   scenario " + pv.scenario_id;
    std::string line2;
    if (!pv.source_format.empty()) line2 += pv.source_format;
    if (!pv.source_version.empty()) line2 += (line2.empty() ? "" : " ") + pv.source_version;
    line2 += (line2.empty() ? "" : "   |   ") + time_label(scene, t);
    char buf[128];
    std::snprintf(buf, sizeof buf, "   |   view %.0f x %.0f m, 1 px = %.3g m", W / s, map_h / s, 1.0 / s);
    line2 += buf;
    c.draw_text(kPad, 12, line1, kText, title_scale);
    c.draw_text(kPad, 12 + 9 * title_scale + 8, line2, kTextDim, ts);
    out.title = line1 + "\n" + line2;
  }
  if (opt.scale_bar) {
    // +y arrow at the right of the title band.
    const std::string up = map.geo_reference.empty() ? "+y" : "+y (N)";
    const double ax = W - kPad - 8.0 * ts, ay0 = 10.0, ay1 = title_h - 10.0;
    c.stroke_polyline({{ax, ay1}, {ax, ay0 + 6.0 * ts}}, 1.0 + ts, kText);
    c.fill_polygon({{ax, ay0}, {ax + 5.0 * ts, ay0 + 9.0 * ts}, {ax - 5.0 * ts, ay0 + 9.0 * ts}}, kText);
    c.draw_text(static_cast<int>(ax - 8.0 * ts) - text_width(up, ts), static_cast<int>((ay0 + ay1) / 2 - 4.0 * ts), up,
                kText, ts);
  }
  if (footer_h > 0) {
    const int y0 = title_h + map_h;
    c.fill_rect(0, y0, W, H, kPanel);
    c.fill_rect(0, y0, W, y0 + 1, kPanelBorder);
    for (size_t i = 0; i < items.size(); ++i) {
      const int col = static_cast<int>(i) / nrows, row = static_cast<int>(i) % nrows;
      const double x = kPad + col * col_w, y = y0 + kPad + row * row_h;
      draw_swatch(c, items[i], x, y, sw, sh, mt);
      c.draw_text(static_cast<int>(x) + sw + 6 * ts, static_cast<int>(y + sh / 2.0 - 3.5 * ts), items[i].label, kText, ts);
      out.legend.push_back(items[i].label);
    }
    if (opt.scale_bar) {
      // Scale bar at the right of the footer: alternating segments, "0" and the length below.
      const double bar_m = round_scale_length(bar_max_px / s);
      const double bar_px = bar_m * s, bar_h = 3.0 * ts + 2;
      const std::string label = metres_label(bar_m);
      const double bx1 = W - kPad - text_width(label, ts) / 2.0, bx0 = bx1 - bar_px;
      const double by = y0 + kPad + 2.0;
      const int segs = bar_px >= 120 ? 4 : 2;
      for (int i = 0; i < segs; ++i)
        c.fill_rect(bx0 + bar_px * i / segs, by, bx0 + bar_px * (i + 1) / segs, by + bar_h, i % 2 ? kDark : kText);
      c.stroke_polyline({{bx0, by}, {bx1, by}, {bx1, by + bar_h}, {bx0, by + bar_h}}, 1.0, kText, true);
      const int ly = static_cast<int>(by + bar_h + 6);
      c.draw_text(static_cast<int>(bx0) - text_width("0", ts) / 2, ly, "0", kText, ts);
      c.draw_text(static_cast<int>(bx1) - text_width(label, ts) / 2, ly, label, kText, ts);
      out.scale_bar_m = bar_m;
    }
  }
  return out;
}

void write_map_png(const MapPlot& plot, const std::string& path) {
  const std::vector<uint8_t>& rgba = plot.image.rgba();
  std::vector<uint8_t> rgb;
  rgb.reserve(rgba.size() / 4 * 3);
  for (size_t i = 0; i < rgba.size(); i += 4) rgb.insert(rgb.end(), {rgba[i], rgba[i + 1], rgba[i + 2]});
  write_png(path, rgb.data(), plot.image.width(), plot.image.height(), 3);
}

void plot_map_png(const Scene& scene, const MapPlotOptions& options, const std::string& path) {
  write_map_png(render_map(scene, options), path);
}

}  // namespace icube::scene
