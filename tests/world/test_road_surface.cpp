// Road-surface fit (engine/world/road_surface.h, conventions §6): a straight
// road between edges (analytic cell count, nothing outside), an exact tilted
// plane, a leaking barrier with the split rule checked cell by cell against a
// brute-force nearest search, a diagonal road at 0.2 m (point barriers leak,
// segment barriers do not), the lattice anchored at the lane minimum (shift
// invariance), determinism of the seeded subsets, degenerate maps and bad
// options, and the real Waymo scenario and CARLA Town07 when ../shared/data
// is present (counts and timings printed, one split block checked against a
// brute-force split rule). The seed margin: a synthetic road whose edge lies
// in the block next to its lanes (analytic counts, exact planes from the
// expanded region), the demo scene's west and south arms across the y = -5 /
// x = -5 block borders, bad margins, and the real maps at 0.2 m with margin
// 10 (a superset of the margin-0 surface).
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/scene_load.h"
#include "world/demo_scene.h"
#include "world/polyline_resample.h"
#include "world/road_surface.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>

using namespace icube;
using world::RoadSurface;
using world::RoadSurfaceOptions;

namespace {

scene::Lane lane(std::vector<glm::dvec3> pts) {
  scene::Lane l;
  l.points = std::move(pts);
  return l;
}

scene::RoadEdge edge(std::vector<glm::dvec3> pts) {
  scene::RoadEdge e;
  e.points = std::move(pts);
  return e;
}

// Lanes along x at y = -3.8, 0, 4 for x in [0, 79.75]; edges at y = ±6 from
// x = -10 to 90. `gap` leaves the top edge open for x in (19, 21).
scene::Map straight_road(bool gap = false) {
  scene::Map m;
  for (double y : {-3.8, 0.0, 4.0}) m.lanes.push_back(lane({{0.0, y, 0.0}, {79.75, y, 0.0}}));
  m.road_edges.push_back(edge({{-10.0, -6.0, 0.0}, {90.0, -6.0, 0.0}}));
  if (gap) {
    m.road_edges.push_back(edge({{-10.0, 6.0, 0.0}, {19.0, 6.0, 0.0}}));
    m.road_edges.push_back(edge({{21.0, 6.0, 0.0}, {90.0, 6.0, 0.0}}));
  } else {
    m.road_edges.push_back(edge({{-10.0, 6.0, 0.0}, {90.0, 6.0, 0.0}}));
  }
  return m;
}

std::vector<glm::dvec3> resampled(const auto& features) {
  std::vector<glm::dvec3> out;
  for (const auto& f : features) world::append_resampled(out, f.points, world::kMapResampleStep);
  return out;
}

double nearest2(const std::vector<glm::dvec3>& pts, const glm::dvec2& q) {
  double best = std::numeric_limits<double>::infinity();
  for (const glm::dvec3& p : pts) {
    const glm::dvec2 d = glm::dvec2(p) - q;
    best = std::min(best, glm::dot(d, d));
  }
  return best;
}

const world::SurfaceBlock& block_with_index(const RoadSurface& s, int x, int y) {
  for (const world::SurfaceBlock& b : s.blocks())
    if (b.block == glm::ivec2(x, y)) return b;
  throw std::runtime_error("no such block");
}

// Lanes along direction (2, 1) through the origin, edges ±6 m to the side; 160 m long.
scene::Map diagonal_road() {
  const glm::dvec3 dir = glm::normalize(glm::dvec3(2.0, 1.0, 0.0)), side(-dir.y, dir.x, 0.0);
  scene::Map m;
  for (double off : {-3.0, 0.0, 3.0}) m.lanes.push_back(lane({side * off, side * off + dir * 160.0}));
  for (double off : {-6.0, 6.0}) m.road_edges.push_back(edge({side * off - dir * 20.0, side * off + dir * 180.0}));
  return m;
}

double side_offset(const glm::dvec2& p) {
  const glm::dvec2 dir = glm::normalize(glm::dvec2(2.0, 1.0));
  return -dir.y * p.x + dir.x * p.y;
}

scene::Map shifted(scene::Map m, const glm::dvec3& s) {
  for (auto& l : m.lanes)
    for (auto& p : l.points) p += s;
  for (auto& e : m.road_edges)
    for (auto& p : e.points) p += s;
  return m;
}

std::string real_file(const char* rel) { return test::test_data_file(rel); }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The first split block of `s` against a brute-force split rule: the mask must be exactly the flood fill
// (the same fit with splitting disabled) intersected with "nearest lane point strictly nearer than
// nearest edge point" over the block and its 8 neighbours.
void check_split_brute_force(const scene::Map& map, const RoadSurface& s, RoadSurfaceOptions o) {
  const world::SurfaceBlock* split = nullptr;
  for (const auto& b : s.blocks())
    if (b.split && !split) split = &b;
  if (!split) return;
  o.dense_fraction = 1.0;  // never split: the flood-filled mask
  const RoadSurface flood = world::build_road_surface(map, o);
  const world::SurfaceBlock& f = block_with_index(flood, split->block.x, split->block.y);
  auto window = [&](const std::vector<glm::dvec3>& pts) {
    std::vector<glm::dvec3> out;
    for (const glm::dvec3& p : pts) {
      const glm::dvec2 b = glm::floor((glm::dvec2(p) - s.anchor()) / o.block_size);
      if (std::abs(b.x - split->block.x) <= 1 && std::abs(b.y - split->block.y) <= 1) out.push_back(p);
    }
    return out;
  };
  const std::vector<glm::dvec3> lanes = window(resampled(map.lanes)), edges = window(resampled(map.road_edges));
  size_t mismatches = 0;
  const int n = split->cells;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const size_t i = static_cast<size_t>(x + n * y);
      const glm::dvec2 c = split->min_corner + (glm::dvec2(x, y) + 0.5) * o.cell;
      const bool want = f.mask[i] && nearest2(lanes, c) < nearest2(edges, c);
      mismatches += (split->mask[i] != 0) != want;
    }
  CHECK(mismatches == 0);
}

// Counts and timings of both configurations on one real map; checks basic sanity.
void check_real_map(const scene::Map& map, const std::string& name) {
  for (bool fine : {false, true}) {
    RoadSurfaceOptions o;
    if (fine) {
      o.cell = 0.2;
      o.barrier_segments = true;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const RoadSurface s = world::build_road_surface(map, o);
    const double t = seconds_since(t0);
    size_t split = 0, fitted = 0;
    for (const auto& b : s.blocks()) split += b.split, fitted += b.plane_fitted;
    const std::vector<glm::dvec3> pts = s.points();
    const std::string config = fine ? " + segment barriers" : "";
    MESSAGE(name << " cell " << o.cell << config << ": " << s.blocks().size()
                 << " blocks (" << split << " split, " << fitted << " fitted), " << pts.size() << " points ("
                 << pts.size() * o.cell * o.cell / 1e4 << " ha), " << t * 1e3 << " ms");
    CHECK(!s.empty());
    CHECK(pts.size() == s.kept_cells());
    CHECK(pts.size() > 1000);
    size_t lane_hits = 0;
    const std::vector<glm::dvec3> lanes = resampled(map.lanes);
    for (const glm::dvec3& p : lanes) lane_hits += s.drivable(p.x, p.y);
    MESSAGE(name << ": " << lane_hits << " of " << lanes.size() << " lane points on the surface");
    CHECK(lane_hits > lanes.size() / 2);
    bool finite = true;
    for (const glm::dvec3& p : pts) finite = finite && std::isfinite(p.z);
    CHECK(finite);
    check_split_brute_force(map, s, o);
  }
}

}  // namespace

TEST_CASE("road surface: straight road between edges, analytic count, nothing outside") {
  const RoadSurface s = world::build_road_surface(straight_road());
  CHECK(s.anchor() == glm::dvec2(0.0, -3.8));
  REQUIRE(s.blocks().size() == 2);
  // Rows from the anchor up to the barrier row of the y = 6 edge ((6 + 3.8) / 0.4 = 24.5 -> row 24).
  for (const auto& b : s.blocks()) {
    CHECK(b.cells == 100);
    CHECK(!b.split);
    CHECK(b.plane_fitted);
    CHECK(b.kept_cells == 24 * 100);
  }
  CHECK(s.kept_cells() == 4800);
  CHECK(s.drivable(10.0, 5.5));
  CHECK(s.drivable(70.0, -3.7));
  CHECK(!s.drivable(10.0, 6.1));
  CHECK(!s.drivable(10.0, 20.0));
  CHECK(!s.drivable(10.0, -4.0));  // below the anchor: no block
  CHECK(!s.drivable(85.0, 0.0));
  CHECK(s.block_at(10.0, -4.0) == nullptr);
  for (const glm::dvec3& p : s.points()) {
    CHECK(p.z == doctest::Approx(0.0).epsilon(1e-12));
    REQUIRE(s.drivable(p.x + 0.2, p.y + 0.2));
  }
}

TEST_CASE("road surface: a tilted plane is fitted exactly, also from a random subset") {
  auto plane_z = [](double x, double y) { return 0.05 * x - 0.02 * y + 3.0; };
  scene::Map m;
  for (double y : {-3.8, 0.0, 4.0})
    m.lanes.push_back(lane({{0.0, y, plane_z(0.0, y)}, {79.75, y, plane_z(79.75, y)}}));
  for (double y : {-6.0, 6.0}) m.road_edges.push_back(edge({{-10.0, y, plane_z(-10.0, y)}, {90.0, y, plane_z(90.0, y)}}));
  for (size_t max_points : {size_t(1500), size_t(7)}) {
    RoadSurfaceOptions o;
    o.max_fit_points = max_points;
    const RoadSurface s = world::build_road_surface(m, o);
    REQUIRE(s.blocks().size() == 2);
    for (const auto& b : s.blocks()) {
      CHECK(b.plane_fitted);
      CHECK(b.plane.c > 0.0);
    }
    for (const glm::dvec3& p : s.points()) REQUIRE(std::abs(p.z - plane_z(p.x, p.y)) < 1e-9);
    for (double x : {1.0, 39.0, 41.0, 79.0}) REQUIRE(std::abs(*s.height(x, 2.0) - plane_z(x, 2.0)) < 1e-9);
  }
}

TEST_CASE("road surface: a leaking barrier splits the block and keeps cells nearer a lane than an edge") {
  const scene::Map m = straight_road(true);
  const RoadSurface s = world::build_road_surface(m);
  REQUIRE(s.blocks().size() == 2);
  const auto& leaky = block_with_index(s, 0, 0);
  const auto& sealed = block_with_index(s, 1, 0);
  CHECK(leaky.split);
  CHECK(!sealed.split);
  CHECK(sealed.kept_cells == 2400);
  // Brute force: every non-barrier cell was reached, so the mask is exactly "lane strictly nearer than edge".
  const std::vector<glm::dvec3> lanes = resampled(m.lanes), edges = resampled(m.road_edges);
  std::vector<uint8_t> barrier(100 * 100, 0);
  for (const glm::dvec3& e : edges) {
    const int cx = static_cast<int>(std::floor((e.x - leaky.min_corner.x) / 0.4));
    const int cy = static_cast<int>(std::floor((e.y - leaky.min_corner.y) / 0.4));
    if (cx >= 0 && cy >= 0 && cx < 100 && cy < 100) barrier[static_cast<size_t>(cx + 100 * cy)] = 1;
  }
  size_t mismatches = 0, kept = 0;
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 100; ++x) {
      const size_t i = static_cast<size_t>(x + 100 * y);
      const glm::dvec2 c = leaky.min_corner + (glm::dvec2(x, y) + 0.5) * 0.4;
      const bool want = !barrier[i] && nearest2(lanes, c) < nearest2(edges, c);
      mismatches += (leaky.mask[i] != 0) != want;
      kept += want;
    }
  CHECK(mismatches == 0);
  CHECK(leaky.kept_cells == kept);
  MESSAGE("leaky block keeps " << kept << " cells (sealed twin: 2400)");
  CHECK(kept > 2000);
  CHECK(kept < 2600);
  CHECK(!s.drivable(30.0, 7.0));
  CHECK(s.drivable(20.0, 4.5));
}

TEST_CASE("road surface: diagonal road at 0.2 m, point barriers leak and segment barriers do not") {
  const scene::Map m = diagonal_road();
  RoadSurfaceOptions o;
  o.cell = 0.2;
  const RoadSurface points_only = world::build_road_surface(m, o);
  o.barrier_segments = true;
  const RoadSurface segments = world::build_road_surface(m, o);
  size_t leaked = 0, outside = 0, split = 0;
  for (const auto& b : points_only.blocks()) leaked += b.split;
  for (const auto& b : segments.blocks()) split += b.split;
  for (const glm::dvec3& p : segments.points()) outside += std::abs(side_offset(glm::dvec2(p) + 0.1)) > 6.0 + 0.2;
  MESSAGE("diagonal road: " << leaked << " of " << points_only.blocks().size() << " blocks leak with point barriers");
  CHECK(leaked > 0);
  CHECK(split == 0);
  CHECK(outside == 0);
  // Inside the strip and inside the blocks, everything is drivable.
  size_t inside = 0, hits = 0;
  for (double t = 1.0; t < 159.0; t += 0.37)
    for (double off = -5.5; off <= 5.5; off += 0.5) {
      const glm::dvec2 dir = glm::normalize(glm::dvec2(2.0, 1.0)), side(-dir.y, dir.x);
      const glm::dvec2 p = dir * t + side * off;
      if (!segments.block_at(p.x, p.y)) continue;
      // Below the lane anchor's row and column the lattice has no room for the road.
      ++inside;
      hits += segments.drivable(p.x, p.y);
    }
  MESSAGE("diagonal road: " << hits << " of " << inside << " strip samples drivable");
  CHECK(hits > inside * 9 / 10);
  // At 0.4 m, 0.25 m point spacing is already tight: no leak.
  o.cell = 0.4;
  o.barrier_segments = false;
  size_t coarse_split = 0;
  const RoadSurface coarse = world::build_road_surface(m, o);
  for (const auto& b : coarse.blocks()) coarse_split += b.split;
  CHECK(coarse_split == 0);
}

TEST_CASE("road surface: the lattice is anchored at the lane minimum, so a shifted map shifts the result") {
  const scene::Map m = straight_road(true);
  const glm::dvec3 shift(1024.0, -2048.0, 5.0);
  const RoadSurface a = world::build_road_surface(m), b = world::build_road_surface(shifted(m, shift));
  CHECK(b.anchor() == a.anchor() + glm::dvec2(shift));
  REQUIRE(a.blocks().size() == b.blocks().size());
  for (size_t i = 0; i < a.blocks().size(); ++i) {
    CHECK(a.blocks()[i].block == b.blocks()[i].block);
    CHECK(a.blocks()[i].mask == b.blocks()[i].mask);
    CHECK(a.blocks()[i].split == b.blocks()[i].split);
  }
  const auto pa = a.points(), pb = b.points();
  REQUIRE(pa.size() == pb.size());
  double worst = 0.0;
  for (size_t i = 0; i < pa.size(); ++i) worst = std::max(worst, glm::length(pb[i] - pa[i] - shift));
  CHECK(worst < 1e-9);
}

TEST_CASE("road surface: the same seed gives the same points, another seed changes only planes") {
  scene::Map m = diagonal_road();
  // Bumpy heights so that different subsets fit different planes.
  for (auto& l : m.lanes) l.points = world::resample_polyline(l.points, 1.0);
  for (auto& l : m.lanes)
    for (size_t i = 0; i < l.points.size(); ++i) l.points[i].z = 0.3 * std::sin(static_cast<double>(i) * 1.7);
  RoadSurfaceOptions o;
  o.max_fit_points = 10;
  o.seed = 1;
  const RoadSurface a = world::build_road_surface(m, o), a2 = world::build_road_surface(m, o);
  CHECK(a.points() == a2.points());
  o.seed = 2;
  const RoadSurface b = world::build_road_surface(m, o);
  REQUIRE(a.blocks().size() == b.blocks().size());
  size_t planes_differ = 0;
  for (size_t i = 0; i < a.blocks().size(); ++i) {
    CHECK(a.blocks()[i].mask == b.blocks()[i].mask);
    planes_differ += a.blocks()[i].plane.d != b.blocks()[i].plane.d || a.blocks()[i].plane.a != b.blocks()[i].plane.a;
  }
  CHECK(planes_differ > 0);
}

TEST_CASE("road surface: empty and degenerate maps") {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  SUBCASE("empty map and edges without lanes") {
    scene::Map m;
    CHECK(world::build_road_surface(m).empty());
    m.road_edges.push_back(edge({{0, 0, 0}, {10, 0, 0}}));
    const RoadSurface s = world::build_road_surface(m);
    CHECK(s.empty());
    CHECK(s.points().empty());
    CHECK(s.block_at(0, 0) == nullptr);
    CHECK(!s.drivable(0, 0));
    CHECK(!s.height(0, 0).has_value());
    CHECK(s.kept_cells() == 0);
  }
  SUBCASE("one-point lane, no edges: the whole block, horizontal plane at its z") {
    scene::Map m;
    m.lanes.push_back(lane({{5.0, 7.0, 2.5}}));
    const RoadSurface s = world::build_road_surface(m);
    REQUIRE(s.blocks().size() == 1);
    CHECK(s.blocks()[0].split);
    CHECK(!s.blocks()[0].plane_fitted);
    CHECK(s.kept_cells() == 100 * 100);
    CHECK(*s.height(30.0, 30.0) == doctest::Approx(2.5));
  }
  SUBCASE("repeated vertices and a straight sloped lane (collinear: median-z fallback)") {
    scene::Map m;
    m.lanes.push_back(lane({{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {10, 0, 1}, {10, 0, 1}}));
    const RoadSurface s = world::build_road_surface(m);
    REQUIRE(s.blocks().size() == 1);
    CHECK(!s.blocks()[0].plane_fitted);
    CHECK(*s.height(0.0, 0.0) == doctest::Approx(0.5).epsilon(0.02));
  }
  SUBCASE("non-finite vertices are dropped, never crash") {
    scene::Map m;
    m.lanes.push_back(lane({{0, 0, 0}, {nan, 0, 0}, {4, 0, 0}, {inf, 1, 0}, {8, 0, 0}}));
    m.lanes.push_back(lane({{nan, nan, nan}}));
    m.road_edges.push_back(edge({{0, 3, 0}, {nan, 3, 0}, {10, 3, 0}, {1e300, 3, 0}}));
    const RoadSurface s = world::build_road_surface(m);
    CHECK(s.anchor() == glm::dvec2(0.0));
    CHECK(!s.empty());
    for (const glm::dvec3& p : s.points()) REQUIRE(std::isfinite(p.z));
    scene::Map all_nan;
    all_nan.lanes.push_back(lane({{nan, 0, 0}, {0, nan, 0}}));
    CHECK(world::build_road_surface(all_nan).empty());
  }
  SUBCASE("bad options throw") {
    const scene::Map m = straight_road();
    auto with = [&](auto change) {
      RoadSurfaceOptions o;
      change(o);
      return o;
    };
    CHECK_THROWS_AS(world::build_road_surface(m, with([](RoadSurfaceOptions& o) { o.cell = 0.0; })), std::invalid_argument);
    CHECK_THROWS_AS(world::build_road_surface(m, with([](RoadSurfaceOptions& o) { o.cell = nan; })), std::invalid_argument);
    CHECK_THROWS_AS(world::build_road_surface(m, with([](RoadSurfaceOptions& o) { o.block_size = -1.0; })),
                    std::invalid_argument);
    CHECK_THROWS_AS(world::build_road_surface(m, with([](RoadSurfaceOptions& o) { o.cell = 1e-4; })),
                    std::invalid_argument);
    CHECK_THROWS_AS(world::build_road_surface(m, with([](RoadSurfaceOptions& o) { o.dense_fraction = 1.5; })),
                    std::invalid_argument);
    CHECK_THROWS_AS(world::build_road_surface(m, with([](RoadSurfaceOptions& o) { o.sub_blocks = 0; })),
                    std::invalid_argument);
    CHECK_THROWS_AS(world::build_road_surface(m, with([](RoadSurfaceOptions& o) { o.max_fit_points = 0; })),
                    std::invalid_argument);
  }
}

TEST_CASE("road surface: block size not a multiple of the cell") {
  RoadSurfaceOptions o;
  o.cell = 0.3;  // 40 / 0.3 = 133.3 -> 134 cells
  const RoadSurface s = world::build_road_surface(straight_road(), o);
  REQUIRE(!s.empty());
  CHECK(s.blocks()[0].cells == 134);
  CHECK(s.drivable(10.0, 2.0));
  CHECK(!s.drivable(10.0, 7.0));
}

TEST_CASE("road surface: real Waymo scenario and CARLA Town07") {
  const std::string waymo = real_file("maps/waymo/motion_data_one_scenario.tfrecord");
  const std::string town07 = real_file("maps/opendrive/carla/Town07.xodr");
  if (waymo.empty() || town07.empty()) {
    MESSAGE("skipped: Waymo scenario or Town07.xodr not found (set ICUBE_TEST_DATA)");
    return;
  }
  check_real_map(scene::load_scene(waymo).map, "waymo");
  check_real_map(scene::load_scene(town07).map, "Town07");
}

namespace {

// Every margin-0 cell is also drivable with a margin (the margin only adds road).
size_t default_cells_lost(const RoadSurface& plain, const RoadSurface& margin) {
  const double half = 0.5 * plain.options().cell;
  size_t lost = 0;
  for (const glm::dvec3& p : plain.points()) lost += !margin.drivable(p.x + half, p.y + half);
  return lost;
}

// Lanes along x at y = 0 and 3 for x in [0, 79.75] (anchor (0, 0)), edges at y = -2.1 and 5.1 for x in
// [-60, 140], all on the plane z = 0.05 x - 0.02 y + 3: the strip y in [-2.1, 0) lies in the block row
// below the lanes (y index -1), and the road runs on past both lane ends into blocks without lanes.
double margin_plane_z(double x, double y) { return 0.05 * x - 0.02 * y + 3.0; }

scene::Map road_over_block_border() {
  scene::Map m;
  for (double y : {0.0, 3.0})
    m.lanes.push_back(lane({{0.0, y, margin_plane_z(0.0, y)}, {79.75, y, margin_plane_z(79.75, y)}}));
  for (double y : {-2.1, 5.1})
    m.road_edges.push_back(edge({{-60.0, y, margin_plane_z(-60.0, y)}, {140.0, y, margin_plane_z(140.0, y)}}));
  return m;
}

}  // namespace

TEST_CASE("road surface: seed margin, a road whose edge lies in the neighbouring block") {
  const scene::Map m = road_over_block_border();
  const RoadSurface plain = world::build_road_surface(m);
  REQUIRE(plain.blocks().size() == 2);
  CHECK(plain.kept_cells() == 2 * 12 * 100);  // rows 0-11 up to the y = 5.1 barrier row (12)
  CHECK(!plain.drivable(10.0, -1.0));          // upstream: the strip below the lane block is lost
  CHECK(plain.block_at(10.0, -1.0) == nullptr);

  RoadSurfaceOptions o;
  o.seed_margin = 10.0;
  const RoadSurface s = world::build_road_surface(m, o);
  CHECK(s.anchor() == plain.anchor());
  // Blocks x -1..2 (lanes within 10 m of x in [-40, 120)) by y -1..0, in lattice order.
  REQUIRE(s.blocks().size() == 8);
  for (size_t i = 0; i < s.blocks().size(); ++i) {
    const world::SurfaceBlock& b = s.blocks()[i];
    CHECK(b.block == glm::ivec2(static_cast<int>(i % 4) - 1, static_cast<int>(i / 4) - 1));
    CHECK(!b.split);
    CHECK(b.plane_fitted);
    // y index 0: rows 0-11; y index -1: rows 95-99 above the y = -2.1 barrier row ((40 - 2.1) / 0.4 = 94.75).
    CHECK(b.kept_cells == (b.block.y == 0 ? 1200u : 500u));
    CHECK((b.lane_points > 0) == (b.block.y == 0 && (b.block.x == 0 || b.block.x == 1)));
  }
  CHECK(s.kept_cells() == 4 * 1700);
  CHECK(default_cells_lost(plain, s) == 0);
  for (double x = -39.9; x < 119.9; x += 0.7) {
    for (double y = -1.95; y < 4.75; y += 0.1) REQUIRE(s.drivable(x, y));
    CHECK(!s.drivable(x, -2.5));
    CHECK(!s.drivable(x, 5.3));
  }
  CHECK(!s.drivable(-45.0, 1.0));  // block x -2 (x < -40) has no lane within 10 m: not built
  CHECK(s.block_at(-45.0, 1.0) == nullptr);
  // The blocks without lanes fit their planes to the edge and lane points of their expanded region: exact.
  for (const glm::dvec3& p : s.points()) REQUIRE(std::abs(p.z - margin_plane_z(p.x, p.y)) < 1e-9);
  for (double x : {-30.0, 10.0, 50.0, 110.0})
    for (double y : {-1.0, 2.0}) REQUIRE(std::abs(*s.height(x, y) - margin_plane_z(x, y)) < 1e-9);

  // With segment barriers at 0.2 m the same strip is found (rows above the -2.1 barrier: 10 of 200).
  o.cell = 0.2;
  o.barrier_segments = true;
  const RoadSurface fine = world::build_road_surface(m, o);
  REQUIRE(fine.blocks().size() == 8);
  for (const world::SurfaceBlock& b : fine.blocks()) CHECK(b.kept_cells == (b.block.y == 0 ? 25u * 200u : 10u * 200u));

  SUBCASE("bad margins throw") {
    for (double bad : {-1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 40.5}) {
      RoadSurfaceOptions b;
      b.seed_margin = bad;
      CHECK_THROWS_AS(world::build_road_surface(m, b), std::invalid_argument);
    }
  }
}

TEST_CASE("road surface: seed margin 10 on the demo scene, roads across the block borders") {
  const scene::Map map = world::make_demo_scene().map;
  RoadSurfaceOptions o;
  o.cell = 0.2;
  o.barrier_segments = true;
  const RoadSurface plain = world::build_road_surface(map, o);
  o.seed_margin = 10.0;
  const auto t0 = std::chrono::steady_clock::now();
  const RoadSurface s = world::build_road_surface(map, o);
  const double t = seconds_since(t0);
  MESSAGE("demo scene at 0.2 m: margin 0 " << plain.blocks().size() << " blocks, " << plain.kept_cells()
                                           << " cells; margin 10 " << s.blocks().size() << " blocks, "
                                           << s.kept_cells() << " cells, " << t * 1e3 << " ms");
  // The lattice is anchored at (-165, -165): block borders at x, y = -5. Lanes at ±1.75, edges at ±6.
  CHECK(s.anchor() == plain.anchor());
  CHECK(s.anchor().y + 4 * o.block_size == doctest::Approx(-5.0));
  CHECK(!plain.drivable(-60.0, -5.5));  // upstream: the strip beyond the border is lost
  CHECK(!plain.drivable(-5.5, 60.0));
  size_t west = 0, south = 0, samples = 0;
  for (double a = -80.0; a <= -50.0; a += 0.5)
    for (double b = -5.7; b <= 5.7; b += 0.1) {
      ++samples;
      west += s.drivable(a, b);    // west arm: road axis y = 0
      south += s.drivable(b, a);   // south arm: road axis x = 0
    }
  CHECK(west == samples);
  CHECK(south == samples);
  for (double a = -80.0; a <= -50.0; a += 5.0) {
    CHECK(s.drivable(a, -5.5));
    CHECK(s.drivable(a, 5.5));
    CHECK(s.drivable(-5.5, a));
    CHECK(s.drivable(5.5, a));
  }
  // Beyond the edges, away from the junction (|x| or |y| > 20 m) and the arm ends: nothing.
  for (double a = 20.0; a <= 150.0; a += 0.5)
    for (double sign : {-1.0, 1.0}) {
      REQUIRE(!s.drivable(sign * a, -6.5));
      REQUIRE(!s.drivable(sign * a, 6.5));
      REQUIRE(!s.drivable(-6.5, sign * a));
      REQUIRE(!s.drivable(6.5, sign * a));
    }
  CHECK(default_cells_lost(plain, s) == 0);
  CHECK(s.kept_cells() > plain.kept_cells());
  for (double a = -150.0; a <= 150.0; a += 10.0) {
    REQUIRE(s.height(a, -5.5).has_value());
    CHECK(std::abs(*s.height(a, -5.5)) < 1e-9);  // flat demo town at z = 0
  }
}

TEST_CASE("road surface: seed margin 10 on the real Waymo scenario and CARLA Town07") {
  const std::string waymo = real_file("maps/waymo/motion_data_one_scenario.tfrecord");
  const std::string town07 = real_file("maps/opendrive/carla/Town07.xodr");
  if (waymo.empty() || town07.empty()) {
    MESSAGE("skipped: Waymo scenario or Town07.xodr not found (set ICUBE_TEST_DATA)");
    return;
  }
  for (const auto& [name, path] : {std::pair{std::string("waymo"), waymo}, std::pair{std::string("Town07"), town07}}) {
    const scene::Map map = scene::load_scene(path).map;
    RoadSurfaceOptions o;
    o.cell = 0.2;
    o.barrier_segments = true;
    const RoadSurface plain = world::build_road_surface(map, o);
    o.seed_margin = 10.0;
    const auto t0 = std::chrono::steady_clock::now();
    const RoadSurface s = world::build_road_surface(map, o);
    const double t = seconds_since(t0);
    size_t split = 0, fitted = 0, lane_less = 0;
    for (const auto& b : s.blocks()) split += b.split, fitted += b.plane_fitted, lane_less += b.lane_points == 0;
    MESSAGE(name << " cell 0.2 + segment barriers + margin 10: " << s.blocks().size() << " blocks (" << lane_less
                 << " without lanes, " << split << " split, " << fitted << " fitted), " << s.kept_cells()
                 << " points (margin 0: " << plain.kept_cells() << "), " << t * 1e3 << " ms");
    CHECK(s.blocks().size() >= plain.blocks().size());
    CHECK(s.kept_cells() >= plain.kept_cells());
    CHECK(default_cells_lost(plain, s) == 0);
    // A block with lanes of its own keeps its margin-0 plane.
    for (const auto& b : plain.blocks()) {
      const world::SurfaceBlock& m = block_with_index(s, b.block.x, b.block.y);
      CHECK(m.plane.a == b.plane.a);
      CHECK(m.plane.d == b.plane.d);
    }
    bool finite = true;
    for (const glm::dvec3& p : s.points()) finite = finite && std::isfinite(p.z);
    CHECK(finite);
  }
}
