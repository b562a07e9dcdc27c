// Road edges of a junction from the UNION of its drivable areas
// (formats.md §2.4): connecting roads overlap each other, so per-road edges
// would cut through the drivable area.
//
// Method: the drivable lane strips of every connecting road (as quads
// between consecutive samples) and of every incoming road within
// kIncomingReach metres of its junction end are rasterised into a BEV mask
// (cell centres, even-odd scanline fill, cells of kCellSize metres, coarser
// when the junction would need more than `max_cells` cells or fill visits,
// junction_raster_cell); marching squares traces
// the mask's boundary; only boundary segments touching a connecting-road cell
// are kept (so the incoming roads, which have their own edges, and the
// junction mouths, which lie inside the union, produce none); the chains are
// simplified (Douglas–Peucker, 0.6 cell) and emitted as Boundary edges with
// z taken from the connecting road covering the adjacent cell. Chains
// shorter than 3 cells are dropped; closed chains repeat their first point.
#pragma once

#include "scene/input_error.h"
#include "scene/opendrive/road_sampling.h"
#include "scene/opendrive/xodr_document.h"
#include "scene/scene.h"

#include <glm/glm.hpp>

#include <array>
#include <string>
#include <vector>

namespace icube::scene::odr {

inline constexpr double kCellSize = 0.15;
inline constexpr double kIncomingReach = 3.0;
// Raster fill visits allowed per cell of a junction's grid budget. The real maps' junctions (CARLA
// Town01/02/07, esmini) visit up to 9.6 cells per grid cell at kCellSize (overlap of the strips'
// bounding boxes up to 8.6, plus up to 10 per metre of cell for the partly covered rows and columns).
inline constexpr double kFillVisitsPerCell = 32.0;

using Quad = std::array<glm::dvec3, 4>;  // a polygon: border a at s_i, s_i+1, border b at s_i+1, s_i

struct JunctionArea {
  std::string junction_id;
  std::vector<Quad> connecting;  // drivable strips of the junction's connecting roads
  std::vector<Quad> incoming;    // drivable strips of incoming roads near their junction end
};

// Appends the quads of runs of adjacent drivable lanes. With end < 0 the whole
// road; with end 0 (start) or 1 (end) only samples within `reach` of that end.
void drivable_quads(const Road& road, const std::vector<SectionSamples>& samples,
                    const std::vector<std::string>& drivable_types, int end, double reach, std::vector<Quad>& out);

// The raster cell of a junction whose connecting roads span bw x bh m: kCellSize, unless the grid
// would hold more than max(1e4, max_cells) cells, or filling its strips would visit more than
// kFillVisitsPerCell times that many (area_sum, side_sum: the summed area and width + height of the
// strips' bounding boxes clipped to the grid; strips that fold over themselves, a wide lane on a
// tight spiral, cover the grid thousands of times). Then the smallest 1.1x step that meets both.
double junction_raster_cell(double bw, double bh, double area_sum, double side_sum, double max_cells);

// max_cells: raster budget of this junction (the reader shares 3.2e7 cells
// among all junctions, at most 4e6 each).
void junction_union_edges(const JunctionArea& area, Map& map, int64_t& next_id, const std::string& file,
                          Diagnostics* diag, double max_cells = 4.0e6);

}  // namespace icube::scene::odr
