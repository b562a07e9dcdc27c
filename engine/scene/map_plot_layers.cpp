// Top-down scene plot, the map itself: the road surface width estimate, the
// map layers (driveways, road surface, crosswalks, speed bumps, lane centres,
// road lines, road edges, stop signs), object boxes with their trails, the ego
// path and the ego box, and the pixel-space primitives they (and the legend
// swatches) are drawn with; plus the public layer colours. See map_plot.h.
#include "scene/map_plot.h"
#include "scene/map_plot_internal.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <unordered_map>

namespace icube::scene {

namespace plot_detail {

namespace {

constexpr double kDefaultLaneWidthM = 3.6;  // road surface around each lane centre when it cannot be estimated
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

std::vector<glm::dvec2> octagon(glm::dvec2 centre, double r) {
  std::vector<glm::dvec2> ring;
  for (int i = 0; i < 8; ++i) {
    const double a = std::numbers::pi / 8.0 + i * std::numbers::pi / 4.0;
    ring.push_back(centre + r * glm::dvec2(std::cos(a), std::sin(a)));
  }
  return ring;
}

// World heading -> pixel direction (y down).
glm::dvec2 pixel_dir(double heading) { return {std::cos(heading), -std::sin(heading)}; }

std::vector<glm::dvec2> box_ring(glm::dvec2 centre, double heading, double len, double wid) {
  const glm::dvec2 f = pixel_dir(heading), l(f.y, -f.x);  // l: world left in pixels
  return {centre + f * (len / 2) + l * (wid / 2), centre + f * (len / 2) - l * (wid / 2),
          centre - f * (len / 2) - l * (wid / 2), centre - f * (len / 2) + l * (wid / 2)};
}

}  // namespace

// ---- road surface width -------------------------------------------------------------------------

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

void draw_stop_sign(Canvas& c, glm::dvec2 centre, double r) {
  c.fill_polygon(octagon(centre, r + 1.2), kWhite);
  c.fill_polygon(octagon(centre, r), kStopSign);
}

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

// ---- the map and the objects -------------------------------------------------------------------

void draw_map_layers(Canvas& c, const MapView& view, const Map& map, const Metrics& mt) {
  for (const Polygon& p : map.driveways)
    if (p.points.size() >= 3) draw_driveway(c, project(view, p.points));
  {
    CoverageMask& m = c.scratch();
    for (const Lane& l : map.lanes)
      if (l.type != LaneType::BikeLane) m.stroke_polyline(project(view, l.points), mt.surface_w);
    c.composite(m, kRoadSurface);
    for (const Lane& l : map.lanes)
      if (l.type == LaneType::BikeLane) m.stroke_polyline(project(view, l.points), std::max(1.5 * mt.s, 1.5));
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
}

void draw_objects(Canvas& c, const MapView& view, const Scene& scene, const MapPlotOptions& opt, int t,
                  const std::vector<PlacedBox>& boxes, const PlacedBox* ego_box, const std::vector<glm::dvec3>& path,
                  const Metrics& mt) {
  const double s = mt.s;
  const int W = c.width(), H = c.height(), ts = mt.ts;
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
    if (ego_box) {
      const glm::dvec2 e = view.to_pixel(ego_box->centre.x, ego_box->centre.y);
      c.fill_circle(e, std::max(ego_box->length * s * 0.9, 10.0), with_opacity(kEgoColour, 0.2));
      draw_box(c, view.to_pixel(ego_box->centre.x, ego_box->centre.y), ego_box->heading,
               std::max(ego_box->length * s, 8.0), std::max(ego_box->width * s, 4.0), kEgoColour, BoxLook::Ego);
    }
  }
}

}  // namespace plot_detail

// ---- public helpers -----------------------------------------------------------------------------

Rgba road_edge_colour(RoadEdgeType type) {
  switch (type) {
    case RoadEdgeType::Boundary: return {226, 230, 238, 255};
    case RoadEdgeType::Median: return {186, 150, 255, 255};
    case RoadEdgeType::Curb: return {132, 196, 255, 255};
    default: return {176, 180, 190, 255};
  }
}

Rgba road_line_colour(RoadLineType type) { return plot_detail::line_style(type).colour; }

Rgba object_colour(ObjectType type) {
  switch (type) {
    case ObjectType::Vehicle: return {74, 158, 255, 255};
    case ObjectType::Pedestrian: return {255, 122, 72, 255};
    case ObjectType::Cyclist: return {96, 222, 122, 255};
    case ObjectType::Sign: return {236, 216, 80, 255};
    default: return {186, 186, 198, 255};
  }
}

}  // namespace icube::scene
