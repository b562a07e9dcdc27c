// Top-down scene plot, the overlays around the map: the legend entries and
// their swatches, the title band (provenance, time, view size), the +y arrow,
// and the footer band with the legend grid and the scale bar; plus the public
// round_scale_length. See map_plot.h.
#include "scene/map_plot.h"
#include "scene/map_plot_internal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <utility>

namespace icube::scene {

namespace plot_detail {

namespace {

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

// ---- bands ----------------------------------------------------------------------------------------

// The title band: file and scenario, then format, time and view size.
void draw_title(Canvas& c, const Scene& scene, int t, const PlotLayout& lay, MapPlot& out) {
  const int W = lay.W, ts = lay.ts, title_scale = lay.title_scale, title_h = lay.title_h, map_h = lay.map_h;
  const double s = lay.s;
  c.fill_rect(0, 0, W, title_h, kPanel);
  c.fill_rect(0, title_h - 1, W, title_h, kPanelBorder);
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

// The +y arrow at the right of the title band.
void draw_up_arrow(Canvas& c, const Map& map, const PlotLayout& lay) {
  const int W = lay.W, ts = lay.ts, title_h = lay.title_h;
  const std::string up = map.geo_reference.empty() ? "+y" : "+y (N)";
  const double ax = W - kPad - 8.0 * ts, ay0 = 10.0, ay1 = title_h - 10.0;
  c.stroke_polyline({{ax, ay1}, {ax, ay0 + 6.0 * ts}}, 1.0 + ts, kText);
  c.fill_polygon({{ax, ay0}, {ax + 5.0 * ts, ay0 + 9.0 * ts}, {ax - 5.0 * ts, ay0 + 9.0 * ts}}, kText);
  c.draw_text(static_cast<int>(ax - 8.0 * ts) - text_width(up, ts), static_cast<int>((ay0 + ay1) / 2 - 4.0 * ts), up,
              kText, ts);
}

// The footer band: the legend grid, column by column, and the scale bar at its right.
void draw_footer(Canvas& c, const MapPlotOptions& opt, const std::vector<LegendItem>& items, const PlotLayout& lay,
                 const Metrics& mt, MapPlot& out) {
  const int W = lay.W, H = lay.H, ts = lay.ts, title_h = lay.title_h, map_h = lay.map_h;
  const int sw = lay.sw, sh = lay.sh, row_h = lay.row_h, col_w = lay.col_w, nrows = lay.nrows;
  const double s = lay.s, bar_max_px = lay.bar_max_px;
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

}  // namespace

// ---- legend ---------------------------------------------------------------------------------

std::vector<LegendItem> legend_items(const Scene& scene, const MapPlotOptions& opt, const std::vector<PlacedBox>& boxes,
                                     bool has_ego_box, double ego_len) {
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

// ---- overlays -------------------------------------------------------------------------------

void draw_overlays(const Scene& scene, const MapPlotOptions& opt, int t, const std::vector<LegendItem>& items,
                   const PlotLayout& lay, const Metrics& mt, MapPlot& out) {
  Canvas& c = out.image;
  draw_title(c, scene, t, lay, out);
  if (opt.scale_bar) draw_up_arrow(c, scene.map, lay);
  if (lay.footer_h > 0) draw_footer(c, opt, items, lay, mt, out);
}

}  // namespace plot_detail

// ---- public helpers -----------------------------------------------------------------------------

double round_scale_length(double max_metres) {
  if (!(max_metres >= 1.0) || !std::isfinite(max_metres)) return 1.0;
  double p = std::pow(10.0, std::floor(std::log10(max_metres)));
  double best = p;
  for (double k : {1.0, 2.0, 5.0, 10.0})
    if (k * p <= max_metres * (1.0 + 1e-12)) best = k * p;
  return best;
}

}  // namespace icube::scene
