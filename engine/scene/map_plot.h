// Top-down pictures of a scene (`icube scene plot`): map layers coloured by
// type, object boxes at one time, the ego path and box, with a title line
// (provenance and time), a legend of the layers present, a scale bar and a
// +y arrow.
//
// Layout, top to bottom: title band, map (world x to the right, world y up,
// one uniform scale), legend band. The width is fixed; the map height follows
// the aspect of the plotted extent, capped so the whole image is at most
// `max_height` pixels high (the extent then shrinks to fit and is centred).
// Thin features keep a minimum pixel width so maps kilometres across still
// show every road.
#pragma once

#include "scene/raster.h"
#include "scene/scene.h"

#include <glm/glm.hpp>

#include <optional>
#include <string>
#include <vector>

namespace icube::scene {

// An axis-aligned window of the world (metres).
struct PlotBounds {
  double min_x = 0.0, min_y = 0.0, max_x = 0.0, max_y = 0.0;
};

struct MapPlotOptions {
  int width = 1600;       // image width in pixels (320 to 16384)
  int max_height = 2400;  // image height cap in pixels
  // Time of the boxes: `time_index` (a Scene::timestamps index) wins over
  // `time` (seconds, nearest timestamp); neither = Scene::current_time_index.
  std::optional<double> time;
  std::optional<int> time_index;
  bool boxes = true;      // object boxes (and the ego box) at that time
  bool ego_path = true;   // the ego trajectory with start/end markers
  bool legend = true;
  bool scale_bar = true;  // scale bar and +y arrow
  double margin_m = 10.0; // world margin around everything drawn (ignored with `bounds`)
  std::optional<PlotBounds> bounds;  // world window; default = everything drawn + margin
};

// How world x/y map to image pixels.
struct MapView {
  double pixels_per_metre = 1.0;
  double world_min_x = 0.0, world_max_y = 0.0;  // world point at pixel (map_x0, map_y0)
  int map_x0 = 0, map_y0 = 0, map_width = 0, map_height = 0;  // the map area in the image
  glm::dvec2 to_pixel(double x, double y) const {
    return {map_x0 + (x - world_min_x) * pixels_per_metre, map_y0 + (world_max_y - y) * pixels_per_metre};
  }
};

struct MapPlot {
  Canvas image;
  MapView view;
  int time_index = -1;       // the timestamp drawn; -1 when the scene has none
  double scale_bar_m = 0.0;  // length of the scale bar; 0 when none was drawn
  double lane_width_m = 0.0; // road surface width drawn around lane centres (estimated from lane spacing)
  std::vector<std::string> legend;  // legend labels, in drawing order
  std::string title;                // the title band's text (two lines)
};

// Throws InputError (naming the scene's source file) when there is nothing to
// plot, a coordinate is not finite, or the time is outside the scene; and
// std::invalid_argument for bad options.
MapPlot render_map(const Scene& scene, const MapPlotOptions& options = {});
// render_map, then write_map_png.
void plot_map_png(const Scene& scene, const MapPlotOptions& options, const std::string& path);
// The plot as an RGB PNG, written atomically to `path`.
void write_map_png(const MapPlot& plot, const std::string& path);

// The timestamp index the options select (-1 for a scene without timestamps).
int plot_time_index(const Scene& scene, const MapPlotOptions& options);

// The largest 1, 2 or 5 × 10^k metres not above `max_metres` (>= 1 m).
double round_scale_length(double max_metres);

// Colours, for tests and tools that want to match the picture.
inline constexpr Rgba kPlotBackground{22, 25, 31, 255};
Rgba road_edge_colour(RoadEdgeType type);
Rgba road_line_colour(RoadLineType type);
Rgba object_colour(ObjectType type);
inline constexpr Rgba kEgoColour{255, 64, 129, 255};
inline constexpr Rgba kEgoPathColour{0, 229, 255, 255};

}  // namespace icube::scene
