// Road edges of a junction from the UNION of its drivable areas
// (formats.md §2.4): connecting roads overlap each other, so per-road edges
// would cut through the drivable area.
//
// Method: the drivable lane strips of every connecting road (as quads
// between consecutive samples) and of every incoming road within
// kIncomingReach metres of its junction end are rasterised into a BEV mask
// (cell centres, even-odd scanline fill, cells of kCellSize metres, coarser
// when the junction would need more than `max_cells`); marching squares traces
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

// max_cells: raster budget of this junction (the reader shares 3.2e7 cells
// among all junctions, at most 4e6 each).
void junction_union_edges(const JunctionArea& area, Map& map, int64_t& next_id, const std::string& file,
                          Diagnostics* diag, double max_cells = 4.0e6);

}  // namespace icube::scene::odr
