// Junction road edges from the union of drivable areas (see junction_edges.h).
#include "scene/opendrive/junction_edges.h"

#include "scene/opendrive/layers.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <unordered_map>

namespace icube::scene::odr {

namespace {

constexpr uint8_t kDrivable = 1, kConnecting = 2;

struct Grid {
  double x0 = 0.0, y0 = 0.0, cell = kCellSize;
  int w = 0, h = 0;
  std::vector<uint8_t> mask;
  std::vector<float> z;
  uint8_t at(int x, int y) const { return mask[static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)]; }
};

// A cell index clamped to [lo, hi] while still a double: an incoming road's quad may lie far outside
// the grid (which spans the connecting roads), where the index would not fit an int.
int clamped_index(double v, int lo, int hi) {
  if (!(v > lo)) return lo;  // also NaN
  if (v >= hi) return hi;
  return static_cast<int>(v);
}

void fill_quad(Grid& g, const Quad& q, uint8_t bits) {
  double min_y = q[0].y, max_y = q[0].y;
  for (const glm::dvec3& p : q) min_y = std::min(min_y, p.y), max_y = std::max(max_y, p.y);
  const int r0 = clamped_index(std::ceil((min_y - g.y0) / g.cell - 0.5), 0, g.h);
  const int r1 = clamped_index(std::floor((max_y - g.y0) / g.cell - 0.5), -1, g.h - 1);
  const float zq = static_cast<float>(0.25 * (q[0].z + q[1].z + q[2].z + q[3].z));
  for (int r = r0; r <= r1; ++r) {
    const double y = g.y0 + (r + 0.5) * g.cell;
    double xs[4];
    int n = 0;
    for (int e = 0; e < 4; ++e) {
      const glm::dvec3& a = q[e];
      const glm::dvec3& b = q[(e + 1) % 4];
      if ((a.y <= y) == (b.y <= y)) continue;  // half-open: each vertex row counted once
      xs[n++] = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
    }
    for (int a = 1; a < n; ++a)  // insertion sort of at most 4 crossings
      for (int b = a; b > 0 && xs[b] < xs[b - 1]; --b) std::swap(xs[b], xs[b - 1]);
    for (int p = 0; p + 1 < n; p += 2) {
      const int c0 = clamped_index(std::ceil((xs[p] - g.x0) / g.cell - 0.5), 0, g.w);
      const int c1 = clamped_index(std::ceil((xs[p + 1] - g.x0) / g.cell - 0.5) - 1.0, -1, g.w - 1);
      for (int c = c0; c <= c1; ++c) {
        const size_t idx = static_cast<size_t>(r) * static_cast<size_t>(g.w) + static_cast<size_t>(c);
        const uint8_t before = g.mask[idx];
        if ((bits & kConnecting) ? !(before & kConnecting) : before == 0) g.z[idx] = zq;
        g.mask[idx] = before | bits;
      }
    }
  }
}

// Marching-squares crossing edge between two cell centres: horizontal (x,y)-(x+1,y) or vertical (x,y)-(x,y+1).
uint64_t edge_id(const Grid& g, int x, int y, bool vertical) {
  return (static_cast<uint64_t>(y) * static_cast<uint64_t>(g.w) + static_cast<uint64_t>(x)) * 2 + (vertical ? 1 : 0);
}

glm::dvec3 edge_point(const Grid& g, uint64_t id) {
  const bool vertical = id & 1;
  const uint64_t cell = id / 2;
  const int x = static_cast<int>(cell % static_cast<uint64_t>(g.w));
  const int y = static_cast<int>(cell / static_cast<uint64_t>(g.w));
  const int x2 = vertical ? x : x + 1, y2 = vertical ? y + 1 : y;
  const size_t i1 = static_cast<size_t>(y) * static_cast<size_t>(g.w) + static_cast<size_t>(x);
  const size_t i2 = static_cast<size_t>(y2) * static_cast<size_t>(g.w) + static_cast<size_t>(x2);
  const float z = g.mask[i1] ? g.z[i1] : g.z[i2];
  return {g.x0 + (0.5 * (x + x2) + 0.5) * g.cell, g.y0 + (0.5 * (y + y2) + 0.5) * g.cell, static_cast<double>(z)};
}

// Douglas–Peucker in the xy plane, iterative.
std::vector<glm::dvec3> simplify(const std::vector<glm::dvec3>& pts, double tol) {
  const size_t n = pts.size();
  if (n <= 2) return pts;
  std::vector<bool> keep(n, false);
  keep.front() = keep.back() = true;
  std::vector<std::pair<size_t, size_t>> stack{{0, n - 1}};
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    const glm::dvec2 pa(pts[a]), pb(pts[b]);
    const glm::dvec2 d = pb - pa;
    const double len = glm::length(d);
    double worst = -1.0;
    size_t wi = a;
    for (size_t i = a + 1; i < b; ++i) {
      const glm::dvec2 v = glm::dvec2(pts[i]) - pa;
      const double dist = len > 1e-12 ? std::fabs(d.x * v.y - d.y * v.x) / len : glm::length(v);
      if (dist > worst) worst = dist, wi = i;
    }
    if (worst > tol) {
      keep[wi] = true;
      stack.push_back({a, wi});
      stack.push_back({wi, b});
    }
  }
  std::vector<glm::dvec3> out;
  for (size_t i = 0; i < n; ++i)
    if (keep[i]) out.push_back(pts[i]);
  return out;
}

}  // namespace

double junction_raster_cell(double bw, double bh, double area_sum, double side_sum, double max_cells) {
  const double cell_budget = std::max(1.0e4, max_cells), visit_budget = kFillVisitsPerCell * cell_budget;
  auto grid_cells = [&](double c) { return (bw / c + 3.0) * (bh / c + 3.0); };
  auto fill_visits = [&](double c) { return area_sum / (c * c) + side_sum / c; };
  double cell = kCellSize;
  if (grid_cells(cell) <= cell_budget && fill_visits(cell) <= visit_budget) return cell;
  cell = std::max({cell, std::sqrt(bw * bh / cell_budget), std::sqrt(area_sum / visit_budget)}) * 1.1 + 1e-9;
  while (grid_cells(cell) > cell_budget || fill_visits(cell) > visit_budget) cell *= 1.1;
  return cell;
}

void drivable_quads(const Road& road, const std::vector<SectionSamples>& samples,
                    const std::vector<std::string>& drivable_types, int end, double reach, std::vector<Quad>& out) {
  for (const SectionSamples& ss : samples) {
    const LaneSection& sec = road.sections[ss.section];
    const size_t nl = sec.lanes.size();
    std::vector<bool> drv(nl);
    for (size_t j = 0; j < nl; ++j) drv[j] = is_drivable(drivable_types, sec.lanes[j].type);
    for (size_t i = 0; i + 1 < ss.s.size(); ++i) {
      if (end == 0 && ss.s[i] > reach) break;
      if (end == 1 && ss.s[i + 1] < road.length - reach) continue;
      size_t j = 0;
      while (j < nl) {
        if (!drv[j]) {
          ++j;
          continue;
        }
        const size_t j0 = j;
        while (j < nl && drv[j]) ++j;
        out.push_back({ss.point(i, j0), ss.point(i + 1, j0), ss.point(i + 1, j), ss.point(i, j)});
      }
    }
  }
}

void junction_union_edges(const JunctionArea& area, Map& map, int64_t& next_id, const std::string& file,
                          Diagnostics* diag, double max_cells) {
  if (area.connecting.empty()) return;
  double min_x = std::numeric_limits<double>::max(), min_y = min_x;
  double max_x = std::numeric_limits<double>::lowest(), max_y = max_x;
  for (const Quad& q : area.connecting)
    for (const glm::dvec3& p : q) {
      min_x = std::min(min_x, p.x), max_x = std::max(max_x, p.x);
      min_y = std::min(min_y, p.y), max_y = std::max(max_y, p.y);
    }
  const double margin = 1.0;
  min_x -= margin, min_y -= margin, max_x += margin, max_y += margin;
  const double bw = max_x - min_x, bh = max_y - min_y;
  // fill_quad visits at most (w/cell + 1) * (h/cell + 1) cells of a quad whose bounding box, clipped
  // to the grid, is w x h.
  double area_sum = 0.0, side_sum = 0.0;
  auto add_extent = [&](const Quad& q) {
    double x0 = max_x, x1 = min_x, y0 = max_y, y1 = min_y;
    for (const glm::dvec3& p : q)
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    const double w = std::min(x1, max_x) - std::max(x0, min_x), h = std::min(y1, max_y) - std::max(y0, min_y);
    if (!(w >= 0.0 && h >= 0.0)) return;  // outside the grid: no row is visited
    area_sum += w * h;
    side_sum += w + h;
  };
  for (const Quad& q : area.connecting) add_extent(q);
  for (const Quad& q : area.incoming) add_extent(q);
  Grid g;
  g.cell = junction_raster_cell(bw, bh, area_sum, side_sum, max_cells);
  if (g.cell > kCellSize && diag)
    diag->warn(file, "junction " + area.junction_id,
               "junction spans " + std::to_string(bw) + " x " + std::to_string(bh) + " m and its drivable strips cover it " +
                   std::to_string(area_sum / std::max(bw * bh, 1e-12)) + " times; edge raster coarsened to " +
                   std::to_string(g.cell) + " m cells");
  g.x0 = min_x - g.cell;  // one empty cell of padding on every side keeps contours closed
  g.y0 = min_y - g.cell;
  g.w = static_cast<int>(std::ceil(bw / g.cell)) + 3;
  g.h = static_cast<int>(std::ceil(bh / g.cell)) + 3;
  g.mask.assign(static_cast<size_t>(g.w) * static_cast<size_t>(g.h), 0);
  g.z.assign(g.mask.size(), 0.0f);
  for (const Quad& q : area.connecting) fill_quad(g, q, kDrivable | kConnecting);
  for (const Quad& q : area.incoming) fill_quad(g, q, kDrivable);
  // The padding must stay empty so every contour closes inside the grid.
  for (int x = 0; x < g.w; ++x) g.mask[static_cast<size_t>(x)] = g.mask[static_cast<size_t>(g.h - 1) * g.w + x] = 0;
  for (int y = 0; y < g.h; ++y) g.mask[static_cast<size_t>(y) * g.w] = g.mask[static_cast<size_t>(y) * g.w + g.w - 1] = 0;

  // Marching squares over blocks of 2x2 cell centres; keep segments next to a connecting-road cell.
  std::vector<std::pair<uint64_t, uint64_t>> segs;
  for (int y = 0; y + 1 < g.h; ++y)
    for (int x = 0; x + 1 < g.w; ++x) {
      const uint8_t c0 = g.at(x, y), c1 = g.at(x + 1, y), c2 = g.at(x + 1, y + 1), c3 = g.at(x, y + 1);
      const int v = (c0 ? 1 : 0) | (c1 ? 2 : 0) | (c2 ? 4 : 0) | (c3 ? 8 : 0);
      if (v == 0 || v == 15) continue;
      const uint64_t bottom = edge_id(g, x, y, false), right = edge_id(g, x + 1, y, true);
      const uint64_t top = edge_id(g, x, y + 1, false), left = edge_id(g, x, y, true);
      auto conn = [](uint8_t c) { return (c & kConnecting) != 0; };
      if (v == 5) {  // saddles: filled corners are kept apart (4-connectivity)
        if (conn(c0)) segs.push_back({bottom, left});
        if (conn(c2)) segs.push_back({top, right});
        continue;
      }
      if (v == 10) {
        if (conn(c1)) segs.push_back({bottom, right});
        if (conn(c3)) segs.push_back({top, left});
        continue;
      }
      if (!(conn(c0) || conn(c1) || conn(c2) || conn(c3))) continue;
      uint64_t e[4];
      int n = 0;
      if ((c0 != 0) != (c1 != 0)) e[n++] = bottom;
      if ((c1 != 0) != (c2 != 0)) e[n++] = right;
      if ((c3 != 0) != (c2 != 0)) e[n++] = top;
      if ((c0 != 0) != (c3 != 0)) e[n++] = left;
      if (n == 2) segs.push_back({e[0], e[1]});
    }

  // Link segments sharing an edge midpoint into chains.
  std::unordered_map<uint64_t, std::array<int, 2>> at;
  at.reserve(segs.size() * 2);
  for (int i = 0; i < static_cast<int>(segs.size()); ++i)
    for (uint64_t e : {segs[i].first, segs[i].second}) {
      auto [it, fresh] = at.try_emplace(e, std::array<int, 2>{-1, -1});
      (it->second[0] < 0 ? it->second[0] : it->second[1]) = i;
    }
  std::vector<bool> used(segs.size(), false);
  auto next_seg = [&](uint64_t e, int from) {
    const std::array<int, 2>& s = at[e];
    const int other = s[0] == from ? s[1] : s[0];
    return (other >= 0 && !used[static_cast<size_t>(other)]) ? other : -1;
  };
  for (size_t s0 = 0; s0 < segs.size(); ++s0) {
    if (used[s0]) continue;
    used[s0] = true;
    std::deque<uint64_t> chain{segs[s0].first, segs[s0].second};
    for (int dir = 0; dir < 2; ++dir) {
      int cur = static_cast<int>(s0);
      for (;;) {
        const uint64_t tip = dir == 0 ? chain.back() : chain.front();
        const int nx = next_seg(tip, cur);
        if (nx < 0) break;
        used[static_cast<size_t>(nx)] = true;
        const uint64_t far = segs[nx].first == tip ? segs[nx].second : segs[nx].first;
        if (dir == 0) chain.push_back(far);
        else chain.push_front(far);
        cur = nx;
      }
    }
    if (chain.size() < 4) continue;  // shorter than 3 cells
    std::vector<glm::dvec3> pts;
    pts.reserve(chain.size());
    for (uint64_t e : chain) pts.push_back(edge_point(g, e));
    RoadEdge edge;
    edge.type = RoadEdgeType::Boundary;
    edge.points = simplify(pts, 0.6 * g.cell);
    edge.id = kRoadEdgeIdBase + next_id++;
    map.road_edges.push_back(std::move(edge));
  }
}

}  // namespace icube::scene::odr
