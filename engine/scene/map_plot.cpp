// Top-down scene plot: the public entry points (render_map, plot_map_png,
// write_map_png), input checks, the time and the objects placed at it, and
// the view: world extent, scale and the bands of the image. The map layers,
// boxes and ego path are drawn in map_plot_layers.cpp; the title, legend,
// scale bar and +y arrow in map_plot_legend.cpp. See map_plot.h.
#include "scene/map_plot.h"

#include "scene/input_error.h"
#include "scene/map_plot_internal.h"
#include "scene/png_write.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace icube::scene {

namespace {

using plot_detail::PlacedBox;

constexpr double kEgoLengthM = 4.8, kEgoWidthM = 2.1;  // ego box when the ego has no track

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

std::string fmt_g(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

double plot_detail::path_length(const std::vector<glm::dvec3>& path) {
  double len = 0.0;
  for (size_t i = 1; i < path.size(); ++i) len += glm::length(glm::dvec2(path[i] - path[i - 1]));
  return len;
}

// ---- public -------------------------------------------------------------------------------------

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
  using namespace plot_detail;
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

  // ---- map layers (bottom to top), then objects, ego path, ego ----
  draw_map_layers(c, view, map, mt);
  draw_objects(c, view, scene, opt, t, boxes, has_ego_box ? &ego_box : nullptr, path, mt);

  // ---- overlays: title band, footer band (legend, scale bar) ----
  const PlotLayout lay{W, H, ts, title_scale, title_h, map_h, footer_h, s, sw, sh, row_h, col_w, nrows, bar_max_px};
  draw_overlays(scene, opt, t, items, lay, mt, out);
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
