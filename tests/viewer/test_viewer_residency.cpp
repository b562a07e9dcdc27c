// viewer/residency.h: the chunk index, the tiles within the residency radius,
// brick subsets, and the GPU world following the camera (background change,
// applied in bounded slices) with rays through the resident part equal to the
// full world's, after every slice.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "render/raycast_cpu.h"
#include "render/raycast_gpu.h"
#include "residency.h"

#include <chrono>
#include <thread>
#include <vector>

using namespace icube;

namespace {

// A 400 m road strip along x (top at z = 0) with a pillar every 25 m.
world::VoxelGrid strip() {
  world::VoxelGrid g;
  for (int x = 0; x < 2000; ++x) {
    for (int y = 0; y < 20; ++y) g.set({x, y, -1}, 18);
    if (x % 125 < 5)
      for (int z = 0; z < 15; ++z) g.set({x, 10, z}, 14);
  }
  return g;
}

}  // namespace

TEST_CASE("viewer residency: tiles, radius and subsets") {
  const world::VoxelGrid g = strip();
  const viewer::ChunkIndex idx(g, 51.2);
  CHECK(idx.tiles().size() == 8);  // x in [0, 400) m: tiles 0..7 of 51.2 m
  size_t bricks = 0;
  for (const auto& [k, b] : idx.tiles()) bricks += b.size();
  CHECK(bricks == g.brick_count());
  const std::vector<viewer::TileKey> near = idx.tiles_within({10.0, 2.0}, 60.0);
  REQUIRE(near.size() == 2);  // tiles 0 and 1 (51.2 .. 102.4 is 41.2 m away), not 2 (92.4 m)
  CHECK(near[0] == viewer::TileKey{0, 0});
  CHECK(near[1] == viewer::TileKey{1, 0});
  const world::VoxelGrid sub = idx.subset(g, near);
  CHECK(sub.brick_count() == idx.tiles().at({0, 0}).size() + idx.tiles().at({1, 0}).size());
  CHECK(sub.get({100, 5, -1}).class_id == 18);
  CHECK(sub.get({900, 5, -1}).class_id == 0);
}

TEST_CASE("viewer residency: the GPU world follows the camera; rays in the resident part match the full world") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = strip();
  viewer::Residency r(ctx, g, 60.0);
  r.update({10.0, 2.0});  // the first set is built at once
  CHECK_FALSE(r.pending());
  CHECK(r.resident({0, 0}));
  CHECK_FALSE(r.resident({3, 0}));
  const size_t first = r.stats().resident_bricks;
  CHECK(first < g.brick_count());
  r.update({20.0, 2.0});  // moved less than R/4: nothing to do
  CHECK_FALSE(r.pending());
  r.update({250.0, 2.0});
  CHECK(r.pending());
  r.finish();
  CHECK(r.stats().swaps == 2);
  CHECK(r.resident({4, 0}));
  CHECK_FALSE(r.resident({0, 0}));

  // Rays down and along the road near x = 250 m hit the same voxels as in the full world.
  std::vector<render::Ray> rays;
  for (int k = 0; k < 40; ++k) rays.push_back({{230.0 + k, 2.0, 3.0}, glm::normalize(glm::dvec3(0.3, 0.1, -1.0))});
  rays.push_back({{240.0, 2.0, 1.0}, {1.0, 0.0, 0.0}});
  render::RaycasterGpu rc(ctx);
  render::RaycastOptions o;
  o.t_max = 30.0;
  const std::vector<shader::RaycastHit> got = rc.cast_rays(r.world().world(), rays, o);
  const std::vector<render::RayResult> want = render::cast_rays_cpu(g, rays, o);
  size_t bad = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const bool hit = (got[i].flags & RAYCAST_FLAG_SEM) != 0;
    if (hit != want[i].sem_hit || (hit && got[i].sem_class != want[i].class_id)) ++bad;
  }
  CHECK(bad == 0);
  CHECK(want[40].sem_hit);  // the pillar at x = 250 m
}

TEST_CASE("viewer residency: a change is applied in bounded slices; every slice leaves a consistent world") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = strip();
  viewer::Residency r(ctx, g, 60.0, 51.2, viewer::kMaxResidentBricks, 40);  // at most 40 bricks per slice
  r.update({10.0, 2.0});
  const size_t first = r.stats().resident_bricks;
  CHECK(r.stats().swaps == 1);
  r.update({250.0, 2.0});
  REQUIRE(r.pending());
  while (!r.ready()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  size_t slices = 0;
  std::vector<render::Ray> rays;
  for (int k = 0; k < 60; ++k) rays.push_back({{200.0 + k, 2.0, 3.0}, glm::normalize(glm::dvec3(0.3, 0.1, -1.0))});
  render::RaycasterGpu rc(ctx);
  render::RaycastOptions o;
  o.t_max = 30.0;
  const std::vector<render::RayResult> want = render::cast_rays_cpu(g, rays, o);
  size_t bad = 0, last_hits = 0;
  while (r.ready()) {
    r.swap();
    ++slices;
    // Each ray either finds what the full world has there or (its tile not loaded yet) nothing.
    const std::vector<shader::RaycastHit> got = rc.cast_rays(r.world().world(), rays, o);
    size_t hits = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const bool hit = (got[i].flags & RAYCAST_FLAG_SEM) != 0;
      if (hit) ++hits;
      if (hit && (!want[i].sem_hit || got[i].sem_class != want[i].class_id)) ++bad;
    }
    CHECK(hits >= last_hits);  // tiles only arrive during the change
    last_hits = hits;
  }
  CHECK(bad == 0);
  const viewer::ResidencyStats& st = r.stats();
  CHECK(st.swaps == 2);
  CHECK(st.last_steps == slices);
  CHECK(slices == (st.last_added + 39) / 40);
  CHECK(slices >= 3);
  CHECK(st.last_removed > 0);
  CHECK(st.resident_bricks != first);
  CHECK(r.resident({4, 0}));
  CHECK_FALSE(r.resident({0, 0}));
  // All rays now match the full world.
  const std::vector<shader::RaycastHit> got = rc.cast_rays(r.world().world(), rays, o);
  size_t diff = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const bool hit = (got[i].flags & RAYCAST_FLAG_SEM) != 0;
    if (hit != want[i].sem_hit || (hit && got[i].sem_class != want[i].class_id)) ++diff;
  }
  CHECK(diff == 0);
}
