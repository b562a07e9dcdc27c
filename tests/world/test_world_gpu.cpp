// GPU world layout: the hash table / brick records built on the CPU, their
// CPU mirror lookup, and world/probe.comp on the device, all against
// VoxelGrid::get for random grids and random queries inside and outside.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "world/gpu_world.h"

#include <random>
#include <tuple>
#include <vector>

using namespace icube;
using world::VoxelGrid;

namespace {

VoxelGrid random_grid(uint32_t seed, int n, int extent) {
  VoxelGrid g;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(-extent, extent), c(1, 22), inst(0, 65535);
  for (int i = 0; i < n; ++i)
    g.set({d(rng), d(rng), d(rng)}, static_cast<uint8_t>(c(rng)), static_cast<uint16_t>(inst(rng)));
  // Voxels at the range limits and at brick corners.
  g.set({world::kMaxIjk, world::kMaxIjk, world::kMaxIjk}, 22, 65535);
  g.set({-world::kMaxIjk - 1, -world::kMaxIjk - 1, -world::kMaxIjk - 1}, 1, 1);
  g.set({-1, -1, -1}, 5, 500);
  g.set({-8, 7, 8}, 6, 600);
  return g;
}

std::vector<glm::ivec3> queries_for(const VoxelGrid& g, uint32_t seed, int n, int extent) {
  std::vector<glm::ivec3> q;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(-extent - 16, extent + 16);
  g.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel&) {
    if (q.size() < static_cast<size_t>(n / 2)) q.push_back(ijk);  // hits
  });
  while (q.size() < static_cast<size_t>(n)) q.push_back({d(rng), d(rng), d(rng)});  // mostly misses
  for (glm::ivec3 e : {glm::ivec3(INT32_MAX), glm::ivec3(INT32_MIN), glm::ivec3(world::kMaxIjk + 1, 0, 0),
                       glm::ivec3(world::kMaxIjk), glm::ivec3(-world::kMaxIjk - 1), glm::ivec3(-1),
                       glm::ivec3(-8, 7, 8), glm::ivec3(-9, 7, 8)})
    q.push_back(e);
  return q;
}

}  // namespace

TEST_CASE("gpu world: host table and records agree with the grid") {
  const VoxelGrid g = random_grid(11, 5000, 60);
  const world::GpuWorldHost h = world::build_gpu_world_host(g);
  CHECK(h.brick_count == g.brick_count());
  CHECK(h.table.size() == h.table_mask + 1u);
  CHECK((h.table.size() & (h.table.size() - 1)) == 0);
  CHECK(2 * g.brick_count() <= h.table.size());
  CHECK(h.bricks.size() == g.brick_count() * WORLD_BRICK_UINTS);
  size_t used = 0;
  for (const auto& e : h.table) used += e.brick != WORLD_EMPTY_SLOT;
  CHECK(used == g.brick_count());
  const auto q = queries_for(g, 12, 20000, 60);
  size_t bad = 0, hits = 0;
  for (const glm::ivec3& ijk : q) {
    const world::Voxel want = g.get(ijk), got = world::lookup_gpu_world_host(h, ijk);
    bad += want.class_id != got.class_id || want.instance != got.instance;
    hits += want.class_id != 0;
  }
  CHECK(bad == 0);
  CHECK(hits >= g.voxel_count());  // every voxel is queried once, random queries hit a few more
  CHECK(hits < q.size());
  // Empty grid: lookups miss.
  const world::GpuWorldHost e = world::build_gpu_world_host(VoxelGrid{});
  CHECK(world::lookup_gpu_world_host(e, {0, 0, 0}).class_id == 0);
}

TEST_CASE("gpu world: world/probe.comp matches VoxelGrid::get") {
  gpu::Context& ctx = test::gpu_context();
  for (auto [seed, n, extent] : {std::tuple{21u, 20000, 80}, std::tuple{22u, 37, 5}, std::tuple{23u, 0, 3}}) {
    CAPTURE(seed);
    const VoxelGrid g = n ? random_grid(seed, n, extent) : VoxelGrid{};
    const world::GpuWorld gw = world::upload_gpu_world(ctx, g);
    const auto q = queries_for(g, seed + 100, 30000, extent);
    const std::vector<world::Voxel> got = world::probe_gpu_world(ctx, gw, q);
    REQUIRE(got.size() == q.size());
    std::vector<uint32_t> want_v, got_v;
    for (size_t i = 0; i < q.size(); ++i) {
      const world::Voxel w = g.get(q[i]);
      want_v.push_back(static_cast<uint32_t>(w.class_id) << 16 | w.instance);
      got_v.push_back(static_cast<uint32_t>(got[i].class_id) << 16 | got[i].instance);
    }
    CHECK(test::equal_report(got_v, want_v, "class<<16|instance"));
  }
}
