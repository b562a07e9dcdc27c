// render_world_top(): the highest voxel per column, coloured by class and shaded by height (world_plot.h).
#include "world/world_plot.h"

#include "scene/png_write.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace icube::world {

const std::array<std::array<uint8_t, 3>, kNumSemanticClasses> kPlotPalette = {{
    {0, 0, 0},        // 0 undefined
    {200, 60, 200},   // 1 car
    {150, 40, 170},   // 2 truck
    {120, 30, 140},   // 3 bus
    {180, 110, 200},  // 4 other vehicle
    {255, 120, 60},   // 5 motorcyclist
    {255, 160, 60},   // 6 bicyclist
    {255, 60, 60},    // 7 pedestrian
    {230, 30, 30},    // 8 sign
    {255, 140, 0},    // 9 traffic light
    {60, 60, 60},     // 10 pole
    {255, 100, 0},    // 11 construction cone
    {255, 180, 120},  // 12 bicycle
    {255, 100, 120},  // 13 motorcycle
    {229, 196, 148},  // 14 building
    {60, 160, 60},    // 15 vegetation
    {120, 80, 40},    // 16 tree trunk
    {240, 200, 40},   // 17 curb
    {110, 110, 115},  // 18 road
    {250, 250, 250},  // 19 lane marker
    {150, 130, 110},  // 20 other ground
    {150, 200, 110},  // 21 walkable
    {170, 170, 200},  // 22 sidewalk
}};

namespace {

constexpr scene::Rgba kEmpty{40, 40, 44, 255};

struct Column {
  int32_t top = std::numeric_limits<int32_t>::min();
  uint8_t class_id = 0;
};

}  // namespace

WorldPlot render_world_top(const VoxelGrid& grid, const WorldPlotOptions& options) {
  WorldPlot plot;
  const IjkBounds b = grid.bounds();
  const double vs = grid.voxel_size();
  if (b.empty()) {
    plot.image = scene::Canvas(64, 64, kEmpty);
    plot.metres_per_pixel = vs;
    plot.min_xy = glm::dvec2(grid.origin());
    return plot;
  }
  const int64_t nx = int64_t(b.max.x) - b.min.x + 1, ny = int64_t(b.max.y) - b.min.y + 1;
  const int64_t longest = std::max(nx, ny);
  const int64_t step = std::max<int64_t>(1, (longest + options.max_pixels - 1) / std::max(1, options.max_pixels));
  const int w = static_cast<int>((nx + step - 1) / step), h = static_cast<int>((ny + step - 1) / step);
  std::vector<Column> cols(static_cast<size_t>(w) * static_cast<size_t>(h));
  grid.for_each_voxel([&](const glm::ivec3& ijk, const Voxel& v) {
    const int px = static_cast<int>((int64_t(ijk.x) - b.min.x) / step);
    const int py = h - 1 - static_cast<int>((int64_t(ijk.y) - b.min.y) / step);
    Column& c = cols[static_cast<size_t>(py) * static_cast<size_t>(w) + static_cast<size_t>(px)];
    if (ijk.z > c.top) c = {ijk.z, v.class_id};
  });
  // Relief relative to the 5th-percentile column top (the ground, robust to pits).
  std::vector<int32_t> tops;
  tops.reserve(cols.size());
  for (const Column& c : cols)
    if (c.class_id) tops.push_back(c.top);
  std::nth_element(tops.begin(), tops.begin() + static_cast<std::ptrdiff_t>(tops.size() / 20), tops.end());
  const int32_t ground = tops[tops.size() / 20];

  plot.image = scene::Canvas(w, h, kEmpty);
  plot.metres_per_pixel = vs * static_cast<double>(step);
  plot.min_xy = glm::dvec2(grid.origin()) + glm::dvec2(b.min.x, b.min.y) * vs;
  std::array<bool, kNumSemanticClasses> present{};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Column& c = cols[static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)];
      if (!c.class_id) continue;
      present[c.class_id] = true;
      const double metres = static_cast<double>(c.top - ground) * vs;
      const double shade = std::clamp(0.85 + options.relief * metres, 0.55, 1.35);
      const auto& rgb = kPlotPalette[c.class_id];
      auto ch = [&](uint8_t v) { return static_cast<uint8_t>(std::clamp(static_cast<double>(v) * shade, 0.0, 255.0)); };
      plot.image.blend(x, y, scene::Rgba{ch(rgb[0]), ch(rgb[1]), ch(rgb[2]), 255}, 1.0);
    }
  if (options.legend && w >= 200 && h >= 120) {
    const int scale = std::max(1, std::min(w, h) / 500);
    const int line = scene::text_height("Ag", scale) + 2 * scale;
    int y = 4 * scale;
    for (int c = 1; c < kNumSemanticClasses; ++c) {
      if (!present[static_cast<size_t>(c)]) continue;
      const auto& rgb = kPlotPalette[static_cast<size_t>(c)];
      plot.image.fill_rect(4.0 * scale, y, 4.0 * scale + line - 2 * scale, y + line - 2 * scale,
                           scene::Rgba{rgb[0], rgb[1], rgb[2], 255});
      plot.image.draw_text(6 * scale + line, y, semantic_class_name(static_cast<uint8_t>(c)),
                           scene::Rgba{255, 255, 255, 255}, scale, scene::Rgba{0, 0, 0, 255});
      y += line;
    }
  }
  return plot;
}

void write_world_png(const WorldPlot& plot, const std::string& path) {
  scene::write_png(path, plot.image.rgba().data(), plot.image.width(), plot.image.height(), 4);
}

}  // namespace icube::world
