// A top-down picture of a chunk plan (`icube world plan -o plan.png`): the
// scene drawn by scene::render_map over a window that holds the map and every
// chunk, with each chunk's 51.2 x 51.2 m footprint (oriented by its frame)
// outlined and lightly filled in a colour cycling with its index, the index
// written at the footprint centre (trajectory mode: 11.5 m to the chunk's
// left, off the ego path), and, in trajectory mode, the key camera
// marked with a dot and a short arrow along its forward axis. A line at the
// map's bottom-left says the mode, the chunk count and the stride.
#pragma once

#include "scene/map_plot.h"
#include "scene/scene.h"
#include "world/chunk_plan.h"

#include <string>

namespace icube::world {

struct PlanPlotOptions {
  int width = 1600;
  int max_height = 2400;
  double margin_m = 10.0;
};

// Throws what scene::render_map throws (InputError, std::invalid_argument).
scene::MapPlot render_plan(const scene::Scene& scene, const ChunkPlan& plan, const PlanPlotOptions& options = {});

// The colour of chunk `index` in the plot.
scene::Rgba chunk_colour(int32_t index);

// render_plan, then scene::write_map_png (atomic).
void write_plan_png(const scene::Scene& scene, const ChunkPlan& plan, const PlanPlotOptions& options,
                    const std::string& path);

}  // namespace icube::world
