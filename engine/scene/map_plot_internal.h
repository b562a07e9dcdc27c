// Private to the map plot (map_plot.cpp, map_plot_layers.cpp,
// map_plot_legend.cpp): the palette, pixel metrics derived from the scale,
// the objects placed at the plotted time, the band layout, and the drawing
// entry points each part provides to the others. Not part of the engine's API.
#pragma once

#include "scene/map_plot.h"
#include "scene/raster.h"
#include "scene/scene.h"

#include <glm/glm.hpp>

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

namespace icube::scene::plot_detail {

// ---- style ------------------------------------------------------------------------------

inline constexpr Rgba kRoadSurface{52, 57, 67, 255};
inline constexpr Rgba kBikeSurface{44, 70, 58, 255};
inline constexpr Rgba kLaneCentre{135, 150, 175, 120};
inline constexpr Rgba kBikeCentre{110, 200, 140, 150};
inline constexpr Rgba kWhite{240, 240, 240, 255};
inline constexpr Rgba kYellow{255, 196, 36, 255};
inline constexpr Rgba kCrosswalk{236, 236, 240, 255};
inline constexpr Rgba kSpeedBump{255, 138, 36, 255};
inline constexpr Rgba kDriveway{92, 130, 118, 255};
inline constexpr Rgba kStopSign{214, 34, 46, 255};
inline constexpr Rgba kPanel{12, 14, 18, 255};
inline constexpr Rgba kPanelBorder{66, 72, 86, 255};
inline constexpr Rgba kText{232, 234, 238, 255};
inline constexpr Rgba kTextDim{150, 158, 172, 255};
inline constexpr Rgba kHalo{10, 11, 14, 220};
inline constexpr Rgba kDark{14, 16, 20, 255};
inline constexpr Rgba kStartMarker{80, 220, 120, 255};
inline constexpr Rgba kEndMarker{255, 92, 72, 255};

inline constexpr int kPad = 12;  // pixels kept free around the drawn extent

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

// ---- the objects at one time (map_plot.cpp) -----------------------------------------------------

struct PlacedBox {
  glm::dvec3 centre{0.0};
  double length = 0.0, width = 0.0, heading = 0.0;
  ObjectType type = ObjectType::Unset;
  bool dynamic = false;
  size_t track = 0;
};

// Length of the path in the x/y plane.
double path_length(const std::vector<glm::dvec3>& path);

// ---- map layers, boxes, ego path (map_plot_layers.cpp) ----------------------------------------

enum class BoxLook { Static, Dynamic, Ego };

// The map's lane width for the road surface (metres, 3.6 to 5.5).
double estimate_lane_width(const Map& map);

// Pixel-space primitives, shared with the legend swatches.
void draw_road_line(Canvas& c, const std::vector<glm::dvec2>& pts, RoadLineType type, double w, double sep, double dash,
                    double gap);
void draw_crosswalk(Canvas& c, const std::vector<glm::dvec2>& ring, double period);
void draw_speed_bump(Canvas& c, const std::vector<glm::dvec2>& ring, double period);
void draw_driveway(Canvas& c, const std::vector<glm::dvec2>& ring);
void draw_stop_sign(Canvas& c, glm::dvec2 centre, double r);
void draw_box(Canvas& c, glm::dvec2 centre, double heading, double len_px, double wid_px, Rgba colour, BoxLook look);
void draw_marker(Canvas& c, glm::dvec2 p, double r, Rgba fill);

// The map layers, bottom to top: driveways, road surface, crosswalks, speed
// bumps, lane centres, road lines, road edges, stop signs.
void draw_map_layers(Canvas& c, const MapView& view, const Map& map, const Metrics& mt);
// Over the map: trails behind moving objects, the ego path with its markers,
// the object boxes (static under moving) and the ego box (`ego_box` may be
// null). `boxes` and `path` are empty when the options turn them off.
void draw_objects(Canvas& c, const MapView& view, const Scene& scene, const MapPlotOptions& opt, int t,
                  const std::vector<PlacedBox>& boxes, const PlacedBox* ego_box, const std::vector<glm::dvec3>& path,
                  const Metrics& mt);

// ---- legend, title, scale bar, +y arrow (map_plot_legend.cpp) --------------------------------

enum class Swatch { Lanes, BikeLanes, Edge, Line, Crosswalk, SpeedBump, Driveway, StopSign, Box, Ego, Path };

struct LegendItem {
  std::string label;
  Swatch swatch;
  Rgba colour{};
  RoadLineType line = RoadLineType::Unknown;
  BoxLook look = BoxLook::Static;
};

// The legend entries for what the plot shows, in drawing order. `ego_len` is
// the ego path length (0 when there is no path of two or more points).
std::vector<LegendItem> legend_items(const Scene& scene, const MapPlotOptions& opt, const std::vector<PlacedBox>& boxes,
                                     bool has_ego_box, double ego_len);

// The image's bands (render_map computes them): title band of `title_h` on
// top, the map (`map_h` high) below it, the footer band (`footer_h`, legend
// grid and scale bar) at the bottom.
struct PlotLayout {
  int W = 0, H = 0;             // image size
  int ts = 1, title_scale = 1;  // text scales (body, title line)
  int title_h = 0, map_h = 0, footer_h = 0;
  double s = 1.0;                 // pixels per metre
  int sw = 0, sh = 0, row_h = 0;  // legend swatch size and row height
  int col_w = 0, nrows = 0;       // legend column width and rows per column
  double bar_max_px = 0.0;        // longest scale bar
};

// The title band (sets out.title), the +y arrow (with opt.scale_bar) and the
// footer band with the legend (sets out.legend) and scale bar (sets
// out.scale_bar_m), drawn over `out.image`.
void draw_overlays(const Scene& scene, const MapPlotOptions& opt, int t, const std::vector<LegendItem>& items,
                   const PlotLayout& lay, const Metrics& mt, MapPlot& out);

}  // namespace icube::scene::plot_detail
