// The road-surface fit of conventions §6 (see road_surface.h for the rules):
// per 40 m block of a lattice anchored at the lane minimum, a BEV barrier
// raster of the road edges, a 4-connected flood fill from the lane cells, the
// nearest-lane-vs-nearest-edge split of leaky blocks and one total-least-squares
// plane per block. Blocks are hashed on their lattice index; only blocks that
// hold lane points are ever allocated. The split rule is exact: a quadtree
// over each sub-block decides whole rectangles from distance bounds and only
// cells near the lane/edge Voronoi boundary get their own nearest queries,
// answered by per-block k-d trees. Random subsets use splitmix64 seeded from
// options.seed and the block's lattice index (independent of block order).
// With options.seed_margin > 0, each block is flood-filled on a raster of the
// block expanded by the margin (whole cells, aligned with the block's own
// cells) and then cropped to its own cells; see build_block_margin.
#include "world/road_surface.h"

#include "world/nearest_points_2d.h"
#include "world/plane_fit.h"

#include "world/polyline_resample.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_set>
#include <utility>

namespace icube::world {

namespace {

// Lattice indices beyond this are treated as garbage input and skipped.
constexpr double kMaxLatticeIndex = 1 << 30;
// A resampled map segment longer than this (metres) is treated as broken.
constexpr double kMaxSegmentLength = 1e5;
// Cells per block side above this are rejected (mask memory).
constexpr int kMaxCellsPerSide = 8192;

uint64_t pack_block(int x, int y) {
  return (static_cast<uint64_t>(static_cast<uint32_t>(x)) << 32) | static_cast<uint64_t>(static_cast<uint32_t>(y));
}

// ---- seeded RNG (splitmix64; portable, unlike the std distributions) -------------

class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  // Uniform in [0, n), n > 0, by rejection (no modulo bias).
  uint64_t below(uint64_t n) {
    const uint64_t threshold = (0 - n) % n;
    for (;;) {
      const uint64_t r = next();
      if (r >= threshold) return r % n;
    }
  }

 private:
  uint64_t state_;
};

uint64_t block_seed(uint64_t seed, const glm::ivec2& b) {
  SplitMix64 mix(seed ^ (pack_block(b.x, b.y) * 0xd6e8feb86659fd93ULL));
  return mix.next();
}

// ---- map points ---------------------------------------------------------------------

bool finite_point(const glm::dvec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// Splits a polyline at non-finite vertices and at absurdly long segments, so
// that garbage input cannot crash the resampler; each run is resampled.
void append_sanitised(std::vector<std::vector<glm::dvec3>>& runs, const std::vector<glm::dvec3>& polyline) {
  std::vector<glm::dvec3> run;
  auto flush = [&]() {
    if (!run.empty()) runs.push_back(resample_polyline(run, kMapResampleStep));
    run.clear();
  };
  for (const glm::dvec3& p : polyline) {
    if (!finite_point(p)) {
      flush();
      continue;
    }
    if (!run.empty()) {
      const double d = glm::length(p - run.back());
      if (!std::isfinite(d) || d > kMaxSegmentLength) flush();
    }
    run.push_back(p);
  }
  flush();
}

template <class Feature>
std::vector<std::vector<glm::dvec3>> resampled_runs(const std::vector<Feature>& features) {
  std::vector<std::vector<glm::dvec3>> runs;
  for (const Feature& f : features) append_sanitised(runs, f.points);
  return runs;
}

std::vector<glm::dvec3> flatten(const std::vector<std::vector<glm::dvec3>>& runs) {
  std::vector<glm::dvec3> out;
  for (const auto& r : runs) out.insert(out.end(), r.begin(), r.end());
  return out;
}

// ---- the block lattice --------------------------------------------------------------

struct Lattice {
  glm::dvec2 anchor{0.0};
  double block = 40.0;
  double cell = 0.4;
  int cells = 100;

  // False when the index would overflow (garbage coordinates).
  bool block_of(double x, double y, glm::ivec2& out) const {
    const double fx = std::floor((x - anchor.x) / block), fy = std::floor((y - anchor.y) / block);
    if (!(std::fabs(fx) < kMaxLatticeIndex && std::fabs(fy) < kMaxLatticeIndex)) return false;
    out = {static_cast<int>(fx), static_cast<int>(fy)};
    return true;
  }
  glm::dvec2 min_corner(const glm::ivec2& b) const {
    return {anchor.x + b.x * block, anchor.y + b.y * block};
  }
};

// Per-block working lists (indices into the flattened point arrays).
struct BlockWork {
  glm::ivec2 index{0};
  std::vector<uint32_t> lanes, edges;
  std::vector<uint32_t> segments;  // indices into the segment list (barrier_segments)
};

struct Segment {
  glm::dvec2 a, b;
};

using PointBins = std::unordered_map<uint64_t, std::vector<uint32_t>>;

// Bins every point into its block (points outside the lattice range are skipped).
PointBins bin_points(const Lattice& lat, const std::vector<glm::dvec3>& pts) {
  PointBins bins;
  for (size_t i = 0; i < pts.size(); ++i) {
    glm::ivec2 b;
    if (lat.block_of(pts[i].x, pts[i].y, b)) bins[pack_block(b.x, b.y)].push_back(static_cast<uint32_t>(i));
  }
  return bins;
}

std::vector<Segment> edge_segments(const std::vector<std::vector<glm::dvec3>>& runs) {
  std::vector<Segment> out;
  for (const auto& r : runs)
    for (size_t i = 0; i + 1 < r.size(); ++i) out.push_back({glm::dvec2(r[i]), glm::dvec2(r[i + 1])});
  return out;
}

// Hands every segment to the existing blocks its bounding box touches.
void bin_segments(const Lattice& lat, const std::vector<Segment>& segs, std::vector<BlockWork>& work,
                  const std::unordered_map<uint64_t, uint32_t>& slot) {
  for (size_t s = 0; s < segs.size(); ++s) {
    glm::ivec2 lo, hi;
    const glm::dvec2 mn = glm::min(segs[s].a, segs[s].b), mx = glm::max(segs[s].a, segs[s].b);
    if (!lat.block_of(mn.x, mn.y, lo) || !lat.block_of(mx.x, mx.y, hi)) continue;
    if (static_cast<int64_t>(hi.x - lo.x + 1) * (hi.y - lo.y + 1) > 16) continue;  // not a resampled segment
    for (int bx = lo.x; bx <= hi.x; ++bx)
      for (int by = lo.y; by <= hi.y; ++by) {
        const auto it = slot.find(pack_block(bx, by));
        if (it != slot.end()) work[it->second].segments.push_back(static_cast<uint32_t>(s));
      }
  }
}

// ---- per-block raster ---------------------------------------------------------------

enum : uint8_t { kFree = 0, kBarrier = 1, kKept = 2, kKeptUpstream = 3 };  // kKeptUpstream: seed margin only

struct Raster {
  int cells = 0;
  double cell = 0.0;
  glm::dvec2 origin{0.0};
  std::vector<uint8_t> state;

  // For points binned into this block: one cell of slack on either side
  // absorbs the rounding between the block and the cell arithmetic.
  bool cell_of(double x, double y, int& cx, int& cy) const {
    const double fx = std::floor((x - origin.x) / cell), fy = std::floor((y - origin.y) / cell);
    if (!(fx >= -1.0 && fy >= -1.0 && fx <= cells && fy <= cells)) return false;
    cx = std::clamp(static_cast<int>(fx), 0, cells - 1);
    cy = std::clamp(static_cast<int>(fy), 0, cells - 1);
    return true;
  }
  // For points from anywhere (the expanded raster of the seed margin): no slack.
  bool cell_in(double x, double y, int& cx, int& cy) const {
    const double fx = std::floor((x - origin.x) / cell), fy = std::floor((y - origin.y) / cell);
    if (!(fx >= 0.0 && fy >= 0.0 && fx < cells && fy < cells)) return false;
    cx = static_cast<int>(fx);
    cy = static_cast<int>(fy);
    return true;
  }
  void mark(int cx, int cy) {
    if (cx >= 0 && cy >= 0 && cx < cells && cy < cells) state[static_cast<size_t>(cx + cells * cy)] = kBarrier;
  }
};

// Marks every cell the segment passes through (supercover: both side cells
// when it crosses a cell corner exactly), so the barrier is 4-connected.
void rasterise_segment(Raster& r, const glm::dvec2& a, const glm::dvec2& b) {
  const glm::dvec2 u0 = (a - r.origin) / r.cell, u1 = (b - r.origin) / r.cell;
  int x = static_cast<int>(std::floor(u0.x)), y = static_cast<int>(std::floor(u0.y));
  const int ex = static_cast<int>(std::floor(u1.x)), ey = static_cast<int>(std::floor(u1.y));
  const int sx = ex > x ? 1 : -1, sy = ey > y ? 1 : -1;
  int nx = std::abs(ex - x), ny = std::abs(ey - y);
  const glm::dvec2 d = u1 - u0;
  const double inf = std::numeric_limits<double>::infinity();
  const double dtx = d.x != 0.0 ? 1.0 / std::fabs(d.x) : inf, dty = d.y != 0.0 ? 1.0 / std::fabs(d.y) : inf;
  double tx = d.x != 0.0 ? (sx > 0 ? (x + 1 - u0.x) : (u0.x - x)) * dtx : inf;
  double ty = d.y != 0.0 ? (sy > 0 ? (y + 1 - u0.y) : (u0.y - y)) * dty : inf;
  r.mark(x, y);
  while (nx > 0 || ny > 0) {
    const bool step_x = ny == 0 || (nx > 0 && tx < ty);
    const bool step_y = nx == 0 || (ny > 0 && ty < tx);
    if (step_x) {
      x += sx, tx += dtx, --nx;
    } else if (step_y) {
      y += sy, ty += dty, --ny;
    } else {  // exactly through a corner: both neighbours, then the diagonal cell
      r.mark(x + sx, y);
      r.mark(x, y + sy);
      x += sx, y += sy, tx += dtx, ty += dty, --nx, --ny;
    }
    r.mark(x, y);
  }
}

void mark_barriers(Raster& r, const BlockWork& w, const std::vector<glm::dvec3>& edges,
                   const std::vector<Segment>& segs) {
  for (uint32_t i : w.edges) {
    int cx, cy;
    if (r.cell_of(edges[i].x, edges[i].y, cx, cy)) r.mark(cx, cy);
  }
  for (uint32_t s : w.segments) rasterise_segment(r, segs[s].a, segs[s].b);
}

// 4-connected flood fill of the free cells connected to cell (sx, sy), by horizontal spans (no division
// per cell: the expanded rasters of the seed margin are flooded over most of their area); returns the
// number of cells it keeps. `stack` is scratch (x, y pairs).
size_t fill_from(Raster& r, int sx, int sy, std::vector<int>& stack) {
  const int n = r.cells;
  uint8_t* const state = r.state.data();
  auto row = [&](int y) { return state + static_cast<size_t>(n) * static_cast<size_t>(y); };
  if (row(sy)[sx] != kFree) return 0;
  size_t kept = 0;
  stack.push_back(sx);
  stack.push_back(sy);
  while (!stack.empty()) {
    const int y = stack.back();
    stack.pop_back();
    const int x = stack.back();
    stack.pop_back();
    uint8_t* const here = row(y);
    if (here[x] != kFree) continue;
    int xl = x, xr = x;
    while (xl > 0 && here[xl - 1] == kFree) --xl;
    while (xr + 1 < n && here[xr + 1] == kFree) ++xr;
    std::fill(here + xl, here + xr + 1, static_cast<uint8_t>(kKept));
    kept += static_cast<size_t>(xr - xl + 1);
    for (const int ny : {y - 1, y + 1}) {
      if (ny < 0 || ny >= n) continue;
      const uint8_t* const next = row(ny);
      bool run = false;  // inside a run of free cells already pushed
      for (int i = xl; i <= xr; ++i) {
        const bool free = next[i] == kFree;
        if (free && !run) stack.push_back(i), stack.push_back(ny);
        run = free;
      }
    }
  }
  return kept;
}

// 4-connected flood fill of free cells from every lane cell; returns the kept count.
size_t flood_from_lanes(Raster& r, const BlockWork& w, const std::vector<glm::dvec3>& lanes,
                        std::vector<int>& stack) {
  size_t kept = 0;
  for (uint32_t i : w.lanes) {
    int cx, cy;
    if (r.cell_of(lanes[i].x, lanes[i].y, cx, cy)) kept += fill_from(r, cx, cy, stack);
  }
  return kept;
}

// ---- nearest-point search for the split rule ----------------------------------------

// One k-d tree per block and kind, built on first use.
class BlockTrees {
 public:
  BlockTrees(const PointBins& bins, const std::vector<glm::dvec3>& pts) : bins_(bins), pts_(pts) {}
  const NearestPoints2d& at(const glm::ivec2& b) {
    const uint64_t key = pack_block(b.x, b.y);
    auto it = trees_.find(key);
    if (it != trees_.end()) return it->second;
    std::vector<glm::dvec2> local;
    const auto bin = bins_.find(key);
    if (bin != bins_.end())
      for (uint32_t i : bin->second) local.emplace_back(pts_[i]);
    return trees_.emplace(key, NearestPoints2d(std::move(local))).first->second;
  }

 private:
  const PointBins& bins_;
  const std::vector<glm::dvec3>& pts_;
  std::unordered_map<uint64_t, NearestPoints2d> trees_;
};

// Nearest-point queries over the points of a block and its 8 neighbours.
class Neighbourhood {
 public:
  Neighbourhood(BlockTrees& trees, const glm::ivec2& b) {
    trees_.push_back(&trees.at(b));  // the block itself first: its points are usually the nearest
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        if (dx != 0 || dy != 0) trees_.push_back(&trees.at(b + glm::ivec2(dx, dy)));
    trees_.erase(std::remove_if(trees_.begin(), trees_.end(), [](const NearestPoints2d* t) { return t->empty(); }),
                 trees_.end());
  }
  bool empty() const { return trees_.empty(); }
  // Squared distance to the nearest point closer than sqrt(limit2), or limit2 when none is.
  double nearest2(const glm::dvec2& q, double limit2) const {
    double best = limit2;
    for (const NearestPoints2d* t : trees_) t->nearest2(q, best);
    return best;
  }

 private:
  std::vector<const NearestPoints2d*> trees_;
};

// Step 3: of the kept cells, keep those whose centre is strictly nearer a lane
// point than an edge point. Each sub-block is refined as a quadtree of cell
// rectangles: with t the rectangle's centre and h the half-diagonal of its
// cell centres, every centre c has d(c) within d(t) ± h, so a rectangle with
// dL(t) + h < dE(t) - h keeps all its cells and one with dE(t) + h < dL(t) - h
// drops them; only rectangles near the lane/edge Voronoi boundary are split
// down to single cells, which are decided exactly. The result does not depend
// on the number of sub-blocks.
class SplitRule {
 public:
  SplitRule(Raster& r, const Neighbourhood& lanes, const Neighbourhood& edges)
      : r_(r), lanes_(lanes), edges_(edges), n_(r.cells), kept_before_(static_cast<size_t>(n_ + 1) * (n_ + 1), 0) {
    for (int y = 0; y < n_; ++y)  // summed-area table of the flood-filled cells
      for (int x = 0; x < n_; ++x)
        kept_before_[sat(x + 1, y + 1)] = kept_before_[sat(x, y + 1)] + kept_before_[sat(x + 1, y)] -
                                          kept_before_[sat(x, y)] + (r_.state[cell(x, y)] == kKept ? 1u : 0u);
  }

  size_t run(int sub_blocks) {
    const Known none{glm::dvec2(0.0), std::numeric_limits<double>::infinity()};
    for (int sb = 0; sb < sub_blocks * sub_blocks; ++sb) {
      const int sx = sb % sub_blocks, sy = sb / sub_blocks;
      refine({sx * n_ / sub_blocks, (sx + 1) * n_ / sub_blocks, sy * n_ / sub_blocks, (sy + 1) * n_ / sub_blocks},
             none);
    }
    return kept_;
  }

 private:
  // Bound slack (metres) so that round-off cannot flip a wholesale decision.
  static constexpr double kSlack = 1e-9;
  struct Rect {
    int x0, x1, y0, y1;  // cells [x0, x1) x [y0, y1)
  };
  struct Known {  // the parent's centre and its lane distance: lane(t) <= lane + |t - at|
    glm::dvec2 at;
    double lane;
  };

  void refine(const Rect& q, const Known& parent) {
    if (q.x0 >= q.x1 || q.y0 >= q.y1 || kept_in(q) == 0) return;
    const double inf = std::numeric_limits<double>::infinity();
    const glm::dvec2 t = r_.origin + (glm::dvec2(q.x0 + q.x1, q.y0 + q.y1) * 0.5) * r_.cell;
    const double dx = q.x1 - q.x0 - 1, dy = q.y1 - q.y0 - 1, h = 0.5 * r_.cell * std::sqrt(dx * dx + dy * dy);
    const double bound = parent.lane + glm::length(t - parent.at) + kSlack;
    const double lane2 = lanes_.nearest2(t, bound < inf ? bound * bound : inf), lane = std::sqrt(lane2);
    if (h == 0.0) return settle(q, lane2 < edges_.nearest2(t, std::nextafter(lane2, inf)));
    // Edges beyond `reach` cannot stop a wholesale keep; the capped distance must then pass the keep test
    // below, so the cap sits a few slacks past its threshold lane + 2h + kSlack (a cap at the threshold
    // itself sent every rectangle without a near edge down to single cells: same masks, 2-3x the time).
    const double reach = lane + 2.0 * h + 4.0 * kSlack;
    const double edge = std::sqrt(edges_.nearest2(t, reach * reach));
    if (lane + h + kSlack < edge - h) return settle(q, true);
    if (edge + h + kSlack < lane - h) return settle(q, false);
    const int xm = (q.x0 + q.x1) / 2, ym = (q.y0 + q.y1) / 2;
    const Known here{t, lane};
    refine({q.x0, xm, q.y0, ym}, here);
    refine({xm, q.x1, q.y0, ym}, here);
    refine({q.x0, xm, ym, q.y1}, here);
    refine({xm, q.x1, ym, q.y1}, here);
  }
  size_t sat(int x, int y) const { return static_cast<size_t>(x) + static_cast<size_t>(n_ + 1) * static_cast<size_t>(y); }
  size_t cell(int x, int y) const { return static_cast<size_t>(x) + static_cast<size_t>(n_) * static_cast<size_t>(y); }
  // Flood-filled cells in q (the table predates any decision; decided rectangles never overlap later ones).
  uint32_t kept_in(const Rect& q) const {
    return kept_before_[sat(q.x1, q.y1)] - kept_before_[sat(q.x0, q.y1)] - kept_before_[sat(q.x1, q.y0)] +
           kept_before_[sat(q.x0, q.y0)];
  }
  void settle(const Rect& q, bool keep) {
    if (keep) {
      kept_ += kept_in(q);
      return;
    }
    for (int y = q.y0; y < q.y1; ++y)
      for (int x = q.x0; x < q.x1; ++x)
        if (r_.state[cell(x, y)] == kKept) r_.state[cell(x, y)] = kFree;
  }

  Raster& r_;
  const Neighbourhood& lanes_;
  const Neighbourhood& edges_;
  int n_;
  std::vector<uint32_t> kept_before_;
  size_t kept_ = 0;
};

size_t split_block(Raster& r, const Neighbourhood& lanes, const Neighbourhood& edges, int sub_blocks) {
  if (edges.empty()) return static_cast<size_t>(std::count(r.state.begin(), r.state.end(), kKept));
  return SplitRule(r, lanes, edges).run(sub_blocks);
}

// ---- plane fit ----------------------------------------------------------------------

// Draws min(k, n) distinct indices of `from` (partial Fisher-Yates).
void draw_subset(std::vector<uint32_t> from, size_t k, SplitMix64& rng, std::vector<glm::dvec3>& out,
                 const std::vector<glm::dvec3>& pts) {
  const size_t take = std::min(k, from.size());
  for (size_t i = 0; i < take; ++i) {
    const size_t j = i + static_cast<size_t>(rng.below(from.size() - i));
    std::swap(from[i], from[j]);
    out.push_back(pts[from[i]]);
  }
}

void fit_block_plane(SurfaceBlock& sb, const BlockWork& w, const RoadSurfaceOptions& o,
                     const std::vector<glm::dvec3>& lanes, const std::vector<glm::dvec3>& edges) {
  SplitMix64 rng(block_seed(o.seed, w.index));
  std::vector<glm::dvec3> pts;
  draw_subset(w.edges, o.max_fit_points, rng, pts, edges);
  draw_subset(w.lanes, o.max_fit_points, rng, pts, lanes);
  sb.plane_fitted = fit_plane(pts, sb.plane);
  if (!sb.plane_fitted) sb.plane = horizontal_plane(pts);
}

// ---- driver ---------------------------------------------------------------------------

void check_options(const RoadSurfaceOptions& o) {
  if (!std::isfinite(o.block_size) || o.block_size <= 0.0)
    throw std::invalid_argument("road surface: block_size must be a finite number of metres > 0");
  if (!std::isfinite(o.cell) || o.cell <= 0.0 || o.cell > o.block_size)
    throw std::invalid_argument("road surface: cell must be finite, > 0 and <= block_size");
  if (o.block_size / o.cell > kMaxCellsPerSide)
    throw std::invalid_argument("road surface: more than 8192 cells per block side");
  if (!(o.dense_fraction >= 0.0 && o.dense_fraction <= 1.0))
    throw std::invalid_argument("road surface: dense_fraction must be in [0, 1]");
  if (o.sub_blocks < 1 || o.sub_blocks > 1024)
    throw std::invalid_argument("road surface: sub_blocks must be in 1 to 1024");
  if (o.max_fit_points < 1) throw std::invalid_argument("road surface: max_fit_points must be >= 1");
  if (!(o.seed_margin >= 0.0 && o.seed_margin <= o.block_size))
    throw std::invalid_argument("road surface: seed_margin must be a finite number of metres in [0, block_size]");
}

int cells_per_side(const RoadSurfaceOptions& o) {
  const double ratio = o.block_size / o.cell;
  const double nearest = std::round(ratio);
  return static_cast<int>(std::fabs(ratio - nearest) <= 1e-9 * nearest ? nearest : std::ceil(ratio));
}

// Everything the per-block steps share.
struct FitContext {
  const Lattice& lat;
  const RoadSurfaceOptions& options;
  const std::vector<glm::dvec3>& lanes;
  const std::vector<glm::dvec3>& edges;
  const std::vector<Segment>& segments;
  BlockTrees lane_trees, edge_trees;  // nearest-point trees of the split rule
  std::vector<int> stack;             // flood-fill scratch
};

// Whole cells of seed margin (seed_margin / cell rounded up, a ratio within 1e-9 of an integer counting as
// that integer), at least one.
int margin_cells(const RoadSurfaceOptions& o) {
  const double ratio = o.seed_margin / o.cell;
  const double nearest = std::round(ratio);
  const double cells = std::fabs(ratio - nearest) <= 1e-9 * std::max(nearest, 1.0) ? nearest : std::ceil(ratio);
  return std::max(1, static_cast<int>(cells));
}

// What the seed-margin path adds to FitContext.
struct MarginContext {
  int cells = 1;                 // margin in cells
  int ring_lo = 1, ring_hi = 1;  // blocks the expanded region reaches below / above the block, per axis
  const PointBins& lane_bins;
  const PointBins& edge_bins;
  const PointBins& segment_bins;  // segment indices per block their bounding box touches
  // scratch, reused from block to block
  Raster wide;
  std::vector<uint32_t> lanes, edges;  // the map points in the expanded region
  std::vector<glm::ivec2> seeds;       // their lane cells
  std::vector<uint32_t> segment_stamp;  // last block that rasterised each segment (dedup across bins)
  uint32_t stamp = 0;
};

// Every block whose expanded region (footprint grown by `reach` metres per side) holds a lane point, in
// lattice order (y, then x).
std::vector<glm::ivec2> margin_blocks(const Lattice& lat, const std::vector<glm::dvec3>& lanes, double reach) {
  std::unordered_set<uint64_t> seen;
  std::vector<glm::ivec2> out;
  glm::ivec2 last_lo(1, 1), last_hi(0, 0);  // the previous point's range (consecutive points usually share it)
  for (const glm::dvec3& p : lanes) {
    glm::ivec2 lo, hi;
    if (!lat.block_of(p.x - reach, p.y - reach, lo) || !lat.block_of(p.x + reach, p.y + reach, hi)) continue;
    if (lo == last_lo && hi == last_hi) continue;
    last_lo = lo, last_hi = hi;
    for (int by = lo.y; by <= hi.y; ++by)
      for (int bx = lo.x; bx <= hi.x; ++bx)
        if (seen.insert(pack_block(bx, by)).second) out.emplace_back(bx, by);
  }
  std::sort(out.begin(), out.end(),
            [](const glm::ivec2& a, const glm::ivec2& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
  return out;
}

// Segment indices binned into every block their bounding box touches (not only built blocks).
PointBins bin_segments_everywhere(const Lattice& lat, const std::vector<Segment>& segs) {
  PointBins bins;
  for (size_t s = 0; s < segs.size(); ++s) {
    glm::ivec2 lo, hi;
    const glm::dvec2 mn = glm::min(segs[s].a, segs[s].b), mx = glm::max(segs[s].a, segs[s].b);
    if (!lat.block_of(mn.x, mn.y, lo) || !lat.block_of(mx.x, mx.y, hi)) continue;
    if (static_cast<int64_t>(hi.x - lo.x + 1) * (hi.y - lo.y + 1) > 16) continue;  // not a resampled segment
    for (int bx = lo.x; bx <= hi.x; ++bx)
      for (int by = lo.y; by <= hi.y; ++by) bins[pack_block(bx, by)].push_back(static_cast<uint32_t>(s));
  }
  return bins;
}

SurfaceBlock build_block(FitContext& ctx, const BlockWork& w) {
  const Lattice& lat = ctx.lat;
  SurfaceBlock sb;
  sb.block = w.index;
  sb.min_corner = lat.min_corner(w.index);
  sb.cells = lat.cells;
  sb.edge_points = w.edges.size();
  sb.lane_points = w.lanes.size();
  Raster r{lat.cells, lat.cell, sb.min_corner, std::vector<uint8_t>(static_cast<size_t>(lat.cells) * lat.cells, kFree)};
  mark_barriers(r, w, ctx.edges, ctx.segments);
  sb.kept_cells = flood_from_lanes(r, w, ctx.lanes, ctx.stack);
  if (static_cast<double>(sb.kept_cells) > ctx.options.dense_fraction * static_cast<double>(r.state.size())) {
    sb.split = true;
    const Neighbourhood lanes(ctx.lane_trees, w.index), edges(ctx.edge_trees, w.index);
    sb.kept_cells = split_block(r, lanes, edges, ctx.options.sub_blocks);
  }
  sb.mask.resize(r.state.size());
  for (size_t i = 0; i < r.state.size(); ++i) sb.mask[i] = r.state[i] == kKept ? 1 : 0;
  fit_block_plane(sb, w, ctx.options, ctx.lanes, ctx.edges);
  return sb;
}

// build_block with the seed margin: steps 1-2 on the block grown by mc.cells cells per side (barriers and
// seeds from the map points and segments that fall in it), cropped to the block's own cells; steps 3-4 as
// in build_block, except that a block without lane points of its own fits its plane to the points of the
// expanded region. `w` holds the block's own points only.
SurfaceBlock build_block_margin(FitContext& ctx, MarginContext& mc, const BlockWork& w) {
  const Lattice& lat = ctx.lat;
  SurfaceBlock sb;
  sb.block = w.index;
  sb.min_corner = lat.min_corner(w.index);
  sb.cells = lat.cells;
  sb.edge_points = w.edges.size();
  sb.lane_points = w.lanes.size();
  const int n = lat.cells, m = mc.cells, wide_n = n + 2 * m;
  Raster& wide = mc.wide;
  wide.cells = wide_n;
  wide.cell = lat.cell;
  wide.origin = sb.min_corner - static_cast<double>(m) * lat.cell;
  wide.state.assign(static_cast<size_t>(wide_n) * static_cast<size_t>(wide_n), kFree);
  mc.lanes.clear();
  mc.edges.clear();
  mc.seeds.clear();
  ++mc.stamp;
  for (int dy = -mc.ring_lo; dy <= mc.ring_hi; ++dy)
    for (int dx = -mc.ring_lo; dx <= mc.ring_hi; ++dx) {
      const uint64_t key = pack_block(w.index.x + dx, w.index.y + dy);
      int cx, cy;
      if (const auto e = mc.edge_bins.find(key); e != mc.edge_bins.end())
        for (uint32_t i : e->second)
          if (wide.cell_in(ctx.edges[i].x, ctx.edges[i].y, cx, cy)) {
            wide.mark(cx, cy);
            mc.edges.push_back(i);
          }
      if (const auto l = mc.lane_bins.find(key); l != mc.lane_bins.end())
        for (uint32_t i : l->second)
          if (wide.cell_in(ctx.lanes[i].x, ctx.lanes[i].y, cx, cy)) {
            mc.seeds.emplace_back(cx, cy);
            mc.lanes.push_back(i);
          }
      if (const auto s = mc.segment_bins.find(key); s != mc.segment_bins.end())
        for (uint32_t i : s->second)
          if (mc.segment_stamp[i] != mc.stamp) {
            mc.segment_stamp[i] = mc.stamp;
            rasterise_segment(wide, ctx.segments[i].a, ctx.segments[i].b);
          }
    }
  for (const glm::ivec2& c : mc.seeds) fill_from(wide, c.x, c.y, ctx.stack);

  Raster r{n, lat.cell, sb.min_corner, std::vector<uint8_t>(static_cast<size_t>(n) * static_cast<size_t>(n))};
  for (int y = 0; y < n; ++y) {
    const auto row = wide.state.begin() + static_cast<std::ptrdiff_t>(m + static_cast<size_t>(wide_n) * static_cast<size_t>(y + m));
    std::copy(row, row + n, r.state.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(n) * static_cast<size_t>(y)));
  }
  sb.kept_cells = static_cast<size_t>(std::count(r.state.begin(), r.state.end(), kKept));
  const double dense = ctx.options.dense_fraction * static_cast<double>(r.state.size());
  if (static_cast<double>(sb.kept_cells) > dense) {
    sb.split = true;
    // What seed_margin = 0 keeps here without a split (the block's own flood fill, bit for bit) stays kept:
    // a margin only adds road. Those cells skip the split rule; the rest of the flood fill goes through it.
    if (!w.lanes.empty()) {
      Raster own{n, lat.cell, sb.min_corner, std::vector<uint8_t>(r.state.size(), kFree)};
      mark_barriers(own, w, ctx.edges, ctx.segments);
      if (static_cast<double>(flood_from_lanes(own, w, ctx.lanes, ctx.stack)) <= dense)
        for (size_t i = 0; i < r.state.size(); ++i)
          if (own.state[i] == kKept) r.state[i] = kKeptUpstream;
    }
    const Neighbourhood lanes(ctx.lane_trees, w.index), edges(ctx.edge_trees, w.index);
    split_block(r, lanes, edges, ctx.options.sub_blocks);
    sb.kept_cells = 0;
    for (uint8_t& c : r.state)
      if (c == kKept || c == kKeptUpstream) c = kKept, ++sb.kept_cells;
  }
  sb.mask.resize(r.state.size());
  for (size_t i = 0; i < r.state.size(); ++i) sb.mask[i] = r.state[i] == kKept ? 1 : 0;
  if (!w.lanes.empty()) {
    fit_block_plane(sb, w, ctx.options, ctx.lanes, ctx.edges);
  } else {
    BlockWork region;
    region.index = w.index;
    region.lanes = mc.lanes;
    region.edges = mc.edges;
    fit_block_plane(sb, region, ctx.options, ctx.lanes, ctx.edges);
  }
  return sb;
}

RoadSurface build_with_margin(const RoadSurfaceOptions& options, const Lattice& lat,
                              const std::vector<std::vector<glm::dvec3>>& edge_runs, const std::vector<glm::dvec3>& lanes,
                              const std::vector<glm::dvec3>& edges, const PointBins& lane_bins,
                              const PointBins& edge_bins) {
  std::vector<Segment> segs;
  PointBins segment_bins;
  if (options.barrier_segments) {
    segs = edge_segments(edge_runs);
    segment_bins = bin_segments_everywhere(lat, segs);
  }
  const int m = margin_cells(options);
  const double reach = m * options.cell, span = lat.cells * options.cell;
  MarginContext mc{m,
                   static_cast<int>(std::ceil(reach / options.block_size)),
                   static_cast<int>(std::floor((span + reach) / options.block_size)),
                   lane_bins,
                   edge_bins,
                   segment_bins,
                   Raster{},
                   {},
                   {},
                   {},
                   std::vector<uint32_t>(segs.size(), 0),
                   0};
  FitContext ctx{lat, options, lanes, edges, segs, BlockTrees(lane_bins, lanes), BlockTrees(edge_bins, edges), {}};
  const std::vector<glm::ivec2> indices = margin_blocks(lat, lanes, reach);
  std::vector<SurfaceBlock> blocks;
  blocks.reserve(indices.size());
  for (const glm::ivec2& b : indices) {
    BlockWork w;
    w.index = b;
    const uint64_t key = pack_block(b.x, b.y);
    if (const auto l = lane_bins.find(key); l != lane_bins.end()) w.lanes = l->second;
    if (const auto e = edge_bins.find(key); e != edge_bins.end()) w.edges = e->second;
    if (const auto s = segment_bins.find(key); s != segment_bins.end()) w.segments = s->second;
    blocks.push_back(build_block_margin(ctx, mc, w));
  }
  return RoadSurface(options, lat.anchor, std::move(blocks));
}

}  // namespace

RoadSurface::RoadSurface(const RoadSurfaceOptions& options, const glm::dvec2& anchor, std::vector<SurfaceBlock> blocks)
    : options_(options), anchor_(anchor), blocks_(std::move(blocks)) {
  for (size_t i = 0; i < blocks_.size(); ++i)
    index_[pack_block(blocks_[i].block.x, blocks_[i].block.y)] = static_cast<uint32_t>(i);
}

const SurfaceBlock* RoadSurface::block_at(double x, double y) const {
  if (blocks_.empty()) return nullptr;
  const Lattice lat{anchor_, options_.block_size, options_.cell, 0};
  glm::ivec2 b;
  if (!lat.block_of(x, y, b)) return nullptr;
  const auto it = index_.find(pack_block(b.x, b.y));
  return it == index_.end() ? nullptr : &blocks_[it->second];
}

bool RoadSurface::drivable(double x, double y) const {
  const SurfaceBlock* b = block_at(x, y);
  if (!b) return false;
  double fx = std::floor((x - b->min_corner.x) / options_.cell), fy = std::floor((y - b->min_corner.y) / options_.cell);
  // A point within round-off of a block border can land one cell outside the block the lattice gave it.
  if (fx == -1.0 || fx == b->cells) fx = std::clamp(fx, 0.0, b->cells - 1.0);
  if (fy == -1.0 || fy == b->cells) fy = std::clamp(fy, 0.0, b->cells - 1.0);
  if (!(fx >= 0.0 && fy >= 0.0 && fx < b->cells && fy < b->cells)) return false;
  const size_t i = static_cast<size_t>(fx) + static_cast<size_t>(b->cells) * static_cast<size_t>(fy);
  return i < b->mask.size() && b->mask[i] != 0;
}

std::optional<double> RoadSurface::height(double x, double y) const {
  const SurfaceBlock* b = block_at(x, y);
  if (!b) return std::nullopt;
  return b->plane.height(x, y);
}

std::vector<glm::dvec3> RoadSurface::points() const {
  std::vector<glm::dvec3> out;
  out.reserve(kept_cells());
  for (const SurfaceBlock& b : blocks_)
    for (int y = 0; y < b.cells; ++y)
      for (int x = 0; x < b.cells; ++x) {
        const size_t i = static_cast<size_t>(x) + static_cast<size_t>(b.cells) * static_cast<size_t>(y);
        if (i >= b.mask.size() || !b.mask[i]) continue;
        const double wx = b.min_corner.x + x * options_.cell, wy = b.min_corner.y + y * options_.cell;
        out.emplace_back(wx, wy, b.plane.height(wx, wy));
      }
  return out;
}

size_t RoadSurface::kept_cells() const {
  size_t n = 0;
  for (const SurfaceBlock& b : blocks_) n += b.kept_cells;
  return n;
}

RoadSurface build_road_surface(const scene::Map& map, const RoadSurfaceOptions& options) {
  check_options(options);
  const std::vector<std::vector<glm::dvec3>> lane_runs = resampled_runs(map.lanes);
  const std::vector<std::vector<glm::dvec3>> edge_runs = resampled_runs(map.road_edges);
  const std::vector<glm::dvec3> lanes = flatten(lane_runs), edges = flatten(edge_runs);
  if (lanes.empty()) return RoadSurface(options, glm::dvec2(0.0), {});

  Lattice lat{glm::dvec2(lanes[0]), options.block_size, options.cell, cells_per_side(options)};
  for (const glm::dvec3& p : lanes) lat.anchor = glm::min(lat.anchor, glm::dvec2(p));
  const PointBins lane_bins = bin_points(lat, lanes), edge_bins = bin_points(lat, edges);
  if (options.seed_margin > 0.0) return build_with_margin(options, lat, edge_runs, lanes, edges, lane_bins, edge_bins);

  // Blocks in lattice order (y, then x), each with its own points.
  std::vector<BlockWork> work;
  for (const auto& bin : lane_bins) {
    const uint64_t key = bin.first;
    BlockWork w;
    w.index = {static_cast<int32_t>(static_cast<uint32_t>(key >> 32)), static_cast<int32_t>(static_cast<uint32_t>(key))};
    work.push_back(std::move(w));
  }
  std::sort(work.begin(), work.end(), [](const BlockWork& a, const BlockWork& b) {
    return a.index.y != b.index.y ? a.index.y < b.index.y : a.index.x < b.index.x;
  });
  std::unordered_map<uint64_t, uint32_t> slot;
  for (size_t i = 0; i < work.size(); ++i) {
    const uint64_t key = pack_block(work[i].index.x, work[i].index.y);
    slot[key] = static_cast<uint32_t>(i);
    work[i].lanes = lane_bins.at(key);
    const auto e = edge_bins.find(key);
    if (e != edge_bins.end()) work[i].edges = e->second;
  }
  std::vector<Segment> segs;
  if (options.barrier_segments) {
    segs = edge_segments(edge_runs);
    bin_segments(lat, segs, work, slot);
  }

  FitContext ctx{lat, options, lanes, edges, segs, BlockTrees(lane_bins, lanes), BlockTrees(edge_bins, edges), {}};
  std::vector<SurfaceBlock> blocks;
  blocks.reserve(work.size());
  for (const BlockWork& w : work) blocks.push_back(build_block(ctx, w));
  return RoadSurface(options, lat.anchor, std::move(blocks));
}

}  // namespace icube::world
