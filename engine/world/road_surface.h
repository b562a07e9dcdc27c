// The road surface: which ground cells are drivable and how high they are
// (conventions §6, InfiniCube's offline `road_surface.npy`).
//
// Algorithm, per 40 m block of a lattice anchored at the minimum x, y of the
// lane points (only blocks that hold lane points are built):
//   1. BEV cells of `cell` metres (0.4 m upstream) over the block. Cells that
//      hold a road-edge point are barriers (with `barrier_segments`, every cell
//      a road-edge segment passes through, so a barrier cannot leak when the
//      cell is finer than the 0.25 m point spacing).
//   2. Keep the 4-connected components of non-barrier cells that contain a
//      lane point (lane centre lines resampled at 0.25 m).
//   3. If the kept cells cover more than `dense_fraction` (70 %) of the block,
//      the barriers leaked: split the block into 4 x 4 sub-blocks and keep, of
//      the kept cells, those whose centre is nearer a lane point than an edge
//      point (nearest over the points of the block and its 8 neighbours).
//   4. Fit one plane per block (total least squares) to at most
//      `max_fit_points` edge points and as many lane points of the block,
//      drawn with a seeded RNG; a block with fewer than 3 non-collinear points
//      gets the horizontal plane through their median z.
// The points (`points()`) are each kept cell's min corner with the block's
// plane height there, as upstream emits them.
//
// `seed_margin` (metres, default 0 = upstream, bit-identical) lets a road
// reach over a block border into a block that holds no lane point. With
// seed_margin = m > 0, m rounded up to whole cells (m'):
//   - a block is built when a lane point lies in its footprint expanded by m'
//     on every side (the "expanded region"; per axis, i.e. within m' in the
//     max norm);
//   - its flood fill (steps 1-2) runs on the expanded region's cells: barriers
//     from the edge points (and, with `barrier_segments`, edge segments) that
//     fall in it, seeds from the lane points that fall in it; then only the
//     block's own cells are kept;
//   - step 3's > dense_fraction test counts the block's own kept cells, and the
//     split rule runs on them with the same nearest-point queries (block and 8
//     neighbours), except that in a block with lane points of its own whose
//     own flood fill (exactly the m = 0 one) is not dense, the cells that fill
//     keeps stay kept: a margin only adds road (without this, a leak that the
//     margin opens round a nearby open road end would split the block and drop
//     e.g. parking strips that m = 0 keeps; Town07 at 0.2 m lost 2.5 % of its
//     m = 0 cells that way);
//   - step 4: a block with lane points of its own fits its plane exactly as
//     with m = 0; a block without them fits to the edge and lane points of its
//     expanded region (same subset sizes and seeding, same horizontal
//     fallback). Chosen over "the nearest built block's plane" because those
//     points are the very road that reaches into the block, at most m' away,
//     while a neighbour's plane is fitted to another 40 m and extrapolated.
// A road's open end within m' of a block lets that block's flood fill run
// around the end of its edges; the leak is caught by step 3 as within one block
// (m = 0 hides such leaks only where the end lies on a block border).
// seed_margin must be finite, >= 0 and <= block_size.
//
// Road-edge and lane points are the map's polylines resampled with
// polyline_resample.h (0.25 m). Tests: tests/world/test_road_surface.cpp.
#pragma once

#include "scene/scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <unordered_map>
#include <vector>

namespace icube::world {

struct RoadSurfaceOptions {
  double block_size = 40.0;
  double cell = 0.4;
  double dense_fraction = 0.7;
  int sub_blocks = 4;
  size_t max_fit_points = 1500;  // per kind (edge, lane)
  uint64_t seed = 0;             // the random subsets of step 4
  bool barrier_segments = false;
  double seed_margin = 0.0;      // metres; 0 = upstream (see above)
};

// a x + b y + c z + d = 0 with c != 0 (normalised so that c > 0).
struct SurfacePlane {
  double a = 0.0, b = 0.0, c = 1.0, d = 0.0;
  double height(double x, double y) const { return -(a * x + b * y + d) / c; }
};

struct SurfaceBlock {
  glm::ivec2 block{0};          // lattice index from the anchor
  glm::dvec2 min_corner{0.0};   // world x, y of the block's min corner
  int cells = 0;                // cells per side (block_size / cell, rounded up)
  std::vector<uint8_t> mask;    // cells * cells, 1 = road surface; index x + cells * y
  SurfacePlane plane;
  bool split = false;           // step 3 applied
  bool plane_fitted = false;    // false: horizontal fallback plane
  size_t edge_points = 0, lane_points = 0;  // points of the map inside the block (not the expanded region)
  size_t kept_cells = 0;
};

class RoadSurface {
 public:
  RoadSurface() = default;
  RoadSurface(const RoadSurfaceOptions& options, const glm::dvec2& anchor, std::vector<SurfaceBlock> blocks);

  const RoadSurfaceOptions& options() const { return options_; }
  const glm::dvec2& anchor() const { return anchor_; }
  const std::vector<SurfaceBlock>& blocks() const { return blocks_; }
  bool empty() const { return blocks_.empty(); }

  // The block that holds world (x, y), or nullptr.
  const SurfaceBlock* block_at(double x, double y) const;
  // True when (x, y) falls in a kept cell (a point within round-off of a block border counts in the
  // border cell of the block the lattice gives it).
  bool drivable(double x, double y) const;
  // The plane height of the block holding (x, y); nullopt outside every block.
  std::optional<double> height(double x, double y) const;
  // Every kept cell's min corner at its plane height (world frame), blocks in order, cells x fastest.
  std::vector<glm::dvec3> points() const;
  size_t kept_cells() const;

 private:
  RoadSurfaceOptions options_;
  glm::dvec2 anchor_{0.0};
  std::vector<SurfaceBlock> blocks_;
  std::unordered_map<uint64_t, uint32_t> index_;  // packed block index -> blocks_ index
};

// Throws std::invalid_argument for bad options. An empty map (no lanes) gives an empty surface.
RoadSurface build_road_surface(const scene::Map& map, const RoadSurfaceOptions& options = {});

}  // namespace icube::world
