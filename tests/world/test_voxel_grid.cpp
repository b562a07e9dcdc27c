// VoxelGrid: set/get/erase at brick boundaries, negative and extreme
// coordinates, deterministic iteration, merge policies, memory vs occupancy,
// world <-> ijk in double far from (0, 0, 0), and greedy meshing counts.
#include <doctest/doctest.h>

#include "world/greedy_mesh.h"
#include "world/voxel_grid.h"

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

using namespace icube;
using world::VoxelGrid;

TEST_CASE("voxel grid: set, get and erase across brick boundaries and signs") {
  VoxelGrid g;
  const std::vector<glm::ivec3> pts = {{0, 0, 0},   {7, 7, 7},   {8, 0, 0},  {-1, 0, 0},  {-8, -8, -8},
                                       {-9, 3, 17}, {-1, -1, -1}, {15, -16, 0}, {world::kMaxIjk, 0, 0},
                                       {-world::kMaxIjk - 1, -world::kMaxIjk - 1, world::kMaxIjk}};
  for (size_t i = 0; i < pts.size(); ++i) g.set(pts[i], static_cast<uint8_t>(1 + i), static_cast<uint16_t>(1000 + i));
  CHECK(g.voxel_count() == pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    CAPTURE(i);
    CHECK(g.get(pts[i]).class_id == 1 + i);
    CHECK(g.get(pts[i]).instance == 1000 + i);
  }
  // Neighbours across each boundary stay empty.
  CHECK_FALSE(g.contains({1, 0, 0}));
  CHECK_FALSE(g.contains({-2, 0, 0}));
  CHECK_FALSE(g.contains({8, 1, 0}));
  CHECK_FALSE(g.contains({world::kMaxIjk - 1, 0, 0}));
  // (-1,0,0) and (0,0,0) are in different bricks; (-8..-1) share one.
  CHECK(world::brick_of({-1, 0, 0}) == glm::ivec3(-1, 0, 0));
  CHECK(world::brick_of({-8, -8, -8}) == glm::ivec3(-1, -1, -1));
  CHECK(world::brick_of({-9, 0, 0}).x == -2);
  CHECK(world::brick_from_key(world::brick_key({-3, 5, -131072})) == glm::ivec3(-3, 5, -131072));
  // Overwrite keeps the count; class 0 erases.
  g.set({0, 0, 0}, 14, 7);
  CHECK(g.voxel_count() == pts.size());
  CHECK(g.get({0, 0, 0}).class_id == 14);
  g.set({0, 0, 0}, 0);
  CHECK_FALSE(g.contains({0, 0, 0}));
  CHECK(g.voxel_count() == pts.size() - 1);
  CHECK_FALSE(g.erase({0, 0, 0}));
  CHECK(g.erase({7, 7, 7}));  // last voxel of brick (0,0,0): the brick goes too
  CHECK(g.find_brick({0, 0, 0}) == nullptr);
  CHECK(g.brick_count() == pts.size() - 2 /* (0,0,0)/(7,7,7) and (-1,-1,-1)/(-8,-8,-8) share */ - 1 /* erased */);
  // Out of range and invalid classes.
  CHECK_THROWS_AS(g.set({world::kMaxIjk + 1, 0, 0}, 1), std::out_of_range);
  CHECK_THROWS_AS(g.set({0, INT32_MIN, 0}, 1), std::out_of_range);
  CHECK_THROWS_AS(g.set({0, 0, 0}, 23), std::invalid_argument);
  CHECK(g.get({INT32_MAX, INT32_MAX, INT32_MAX}).class_id == 0);
  CHECK_FALSE(g.erase({INT32_MIN, 0, 0}));
  // Bounds and histogram.
  const world::IjkBounds b = g.bounds();
  CHECK(b.min == glm::ivec3(-world::kMaxIjk - 1, -world::kMaxIjk - 1, -8));
  CHECK(b.max == glm::ivec3(world::kMaxIjk, 3, world::kMaxIjk));
  const auto h = g.class_histogram();
  uint64_t total = 0;
  for (uint64_t n : h) total += n;
  CHECK(total == g.voxel_count());
  CHECK(h[0] == 0);
  CHECK(h[3] == 1);
}

TEST_CASE("voxel grid: world <-> ijk in double keeps millimetres 100 km out") {
  const glm::dvec3 origin(100000.0, -250000.0, 12.3456789);
  VoxelGrid g(origin);
  CHECK(g.world_to_ijk(origin) == glm::ivec3(0));
  CHECK(g.world_to_ijk(origin - glm::dvec3(1e-9)) == glm::ivec3(-1));
  CHECK(g.world_to_ijk(origin + glm::dvec3(0.2 * 3 + 1e-6, -0.2 * 5 + 1e-6, 0.1999)) == glm::ivec3(3, -5, 0));
  const glm::dvec3 c = g.ijk_to_world({123456, -654321, 7});
  CHECK(std::abs(c.x - (100000.0 + 123456.5 * 0.2)) < 1e-6);
  CHECK(std::abs(c.y - (-250000.0 - 654320.5 * 0.2)) < 1e-6);
  CHECK(g.world_to_ijk(c) == glm::ivec3(123456, -654321, 7));
  VoxelGrid zero;  // fVDB convention: centre of ijk = ijk * 0.2 + 0.1
  CHECK(zero.ijk_to_world({2, -1, 0}).x == doctest::Approx(0.5));
  CHECK(zero.ijk_to_world({2, -1, 0}).y == doctest::Approx(-0.1));
  CHECK(zero.world_to_ijk({1e12, 0, 0}).x == INT32_MAX);  // clamped, then out of range
  CHECK_FALSE(world::ijk_in_range(zero.world_to_ijk({1e12, 0, 0})));
  CHECK_FALSE(world::ijk_in_range(zero.world_to_ijk({0, std::nan(""), 0})));
}

TEST_CASE("voxel grid: iteration is sorted by brick key regardless of insertion order") {
  std::mt19937 rng(17);
  std::uniform_int_distribution<int> d(-40, 40);
  std::vector<std::pair<glm::ivec3, uint8_t>> pts;
  for (int i = 0; i < 3000; ++i) pts.push_back({{d(rng), d(rng), d(rng)}, static_cast<uint8_t>(1 + i % 22)});
  VoxelGrid a, b;
  for (const auto& p : pts) a.set(p.first, p.second);
  for (auto it = pts.rbegin(); it != pts.rend(); ++it) b.set(it->first, it->second);  // reverse: later writes differ
  std::vector<glm::ivec3> ia, ib;
  a.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel&) { ia.push_back(ijk); });
  b.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel&) { ib.push_back(ijk); });
  CHECK(ia.size() == a.voxel_count());
  CHECK(ia == ib);
  uint64_t prev_key = 0;
  int prev_bit = -1;
  bool ordered = true;
  for (const glm::ivec3& p : ia) {
    const uint64_t k = world::brick_key(world::brick_of(p));
    const int bit = world::voxel_bit(p);
    if (k < prev_key || (k == prev_key && bit <= prev_bit)) ordered = false;
    prev_key = k;
    prev_bit = bit;
  }
  CHECK(ordered);
}

TEST_CASE("voxel grid: merge policies") {
  VoxelGrid a, b;
  a.set({0, 0, 0}, 1, 5);
  a.set({1, 0, 0}, 2, 6);
  b.set({1, 0, 0}, 3, 7);
  b.set({-20, 0, 0}, 4, 8);
  VoxelGrid keep = a;
  CHECK(keep.merge(b, world::MergePolicy::ExistingWins) == 1);
  CHECK(keep.get({1, 0, 0}).class_id == 2);
  CHECK(keep.get({1, 0, 0}).instance == 6);
  CHECK(keep.get({-20, 0, 0}).class_id == 4);
  CHECK(keep.voxel_count() == 3);
  VoxelGrid over = a;
  CHECK(over.merge(b, world::MergePolicy::Overwrite) == 2);
  CHECK(over.get({1, 0, 0}).class_id == 3);
  CHECK(over.get({1, 0, 0}).instance == 7);
  CHECK(over.get({0, 0, 0}).class_id == 1);
  CHECK(over.voxel_count() == 3);
  VoxelGrid shifted(glm::dvec3(0.1, 0, 0));
  CHECK_THROWS_AS(over.merge(shifted, world::MergePolicy::Overwrite), std::invalid_argument);
}

TEST_CASE("voxel grid: memory grows with occupied bricks, not with extent") {
  VoxelGrid sparse, dense;
  // 64 voxels 100 km apart vs a solid 16^3 block (8 bricks).
  for (int i = 0; i < 64; ++i) sparse.set({i * 200000 - 6000000, (i % 2) * 1000000, -i * 100000}, 18);
  for (int x = 0; x < 16; ++x)
    for (int y = 0; y < 16; ++y)
      for (int z = 0; z < 16; ++z) dense.set({x, y, z}, 14);
  CHECK(sparse.brick_count() == 64);
  CHECK(dense.brick_count() == 8);
  CHECK(dense.voxel_count() == 4096);
  MESSAGE("64 scattered voxels: " << sparse.memory_bytes() << " B; 4096 voxels in 8 bricks: " << dense.memory_bytes()
                                  << " B");
  const double per_brick = static_cast<double>(sparse.memory_bytes()) / 64.0;
  CHECK(per_brick < 2.5 * sizeof(world::Brick));
  CHECK(dense.memory_bytes() < sparse.memory_bytes());
  // Erasing everything frees the bricks.
  for (int x = 0; x < 16; ++x)
    for (int y = 0; y < 16; ++y)
      for (int z = 0; z < 16; ++z) dense.erase({x, y, z});
  CHECK(dense.brick_count() == 0);
  CHECK(dense.voxel_count() == 0);
  CHECK(dense.bounds().empty());
}

TEST_CASE("greedy mesh: one voxel is 6 quads, a 2x1x1 block 6 rectangles, a 3x3 slab 6") {
  VoxelGrid g;
  g.set({-1, 0, 0}, 18);
  auto q = world::greedy_mesh(g);
  CHECK(q.size() == 6);
  for (const auto& m : q) CHECK(m.du * m.dv == 1);
  g.set({0, 0, 0}, 18);
  q = world::greedy_mesh(g);
  CHECK(q.size() == 6);
  int area = 0;
  for (const auto& m : q) area += m.du * m.dv;
  CHECK(area == 10);
  // Different classes do not merge: 2 voxels of different class -> 10 faces, 10 quads.
  g.set({0, 0, 0}, 14);
  CHECK(world::greedy_mesh(g).size() == 10);
  VoxelGrid slab;
  for (int x = 6; x < 9; ++x)
    for (int y = -1; y < 2; ++y) slab.set({x, y, 3}, 22);  // crosses brick boundaries in x and y
  q = world::greedy_mesh(slab);
  CHECK(q.size() == 6);
  // An L shape (3 voxels) in one plane: top/bottom need 2 rectangles each, 8 side quads merge to 6... total 10.
  VoxelGrid l;
  l.set({0, 0, 0}, 1);
  l.set({1, 0, 0}, 1);
  l.set({0, 1, 0}, 1);
  q = world::greedy_mesh(l);
  area = 0;
  for (const auto& m : q) area += m.du * m.dv;
  CHECK(area == 14);  // 3 * 6 - 2 * 2 shared faces
  CHECK(q.size() == 10);
}
