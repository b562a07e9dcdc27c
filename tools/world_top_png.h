// The top-down PNG that `icube world plot` and the --png option of `world
// build` and `world insert` write (engine/world/world_plot.h), with its
// "wrote ..." line.
#pragma once

#include "world/voxel_grid.h"
#include "world/world_plot.h"

#include <cstdio>
#include <string>

namespace icube::tools {

inline void write_top_png(const world::VoxelGrid& g, const std::string& path, int max_pixels = 4096) {
  world::WorldPlotOptions o;
  o.max_pixels = max_pixels;
  const world::WorldPlot p = world::render_world_top(g, o);
  world::write_world_png(p, path);
  std::printf("wrote %s (%d x %d px, %.2f m/px)\n", path.c_str(), p.image.width(), p.image.height(),
              p.metres_per_pixel);
}

}  // namespace icube::tools
