// A top-down picture of a voxel world (`icube world build --png`, `icube world plot`):
// every x-y column shows its highest voxel's class, shaded by height so
// buildings, trees and curbs read as relief. North (+y) is up.
//
// Colours come from kPlotPalette, one distinct colour per class (the guidance
// palette of semantics.h merges classes, e.g. road and other ground). Empty
// columns are dark grey. A world larger than max_pixels on a side is drawn
// at a coarser scale: a pixel then shows the highest voxel of its footprint.
#pragma once

#include "scene/raster.h"
#include "world/semantics.h"
#include "world/voxel_grid.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace icube::world {

// One RGB colour per class id for maps and plots (not the guidance palette).
extern const std::array<std::array<uint8_t, 3>, kNumSemanticClasses> kPlotPalette;

struct WorldPlotOptions {
  int max_pixels = 4096;      // longest side
  double relief = 0.04;       // brightness change per metre above the lowest ground
  bool legend = true;         // a class legend (classes present) in the top-left corner
};

struct WorldPlot {
  scene::Canvas image{1, 1, scene::Rgba{}};  // row 0 = north
  double metres_per_pixel = 0.0;
  glm::dvec2 min_xy{0.0};     // world x, y of the picture's south-west corner
};

WorldPlot render_world_top(const VoxelGrid& grid, const WorldPlotOptions& options = {});
void write_world_png(const WorldPlot& plot, const std::string& path);  // atomic

}  // namespace icube::world
