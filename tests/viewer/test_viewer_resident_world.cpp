// viewer/resident_world.h: a persistent GPU world changed brick by brick
// (removals, additions in slices, car overlays) answers every probe exactly as
// a world built from scratch from the same bricks (render::OverlayWorld with
// the same car cells), and its bounds and revisions follow the changes.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "render/buffers/overlay_world.h"
#include "resident_world.h"
#include "world/gpu_world.h"

#include <algorithm>
#include <cstdio>
#include <random>
#include <vector>

using namespace icube;

namespace {

// Bricks spread over a 24 x 6 x 3 brick box with random classes and instances (fixed seed).
world::VoxelGrid random_world(uint32_t seed) {
  world::VoxelGrid g;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(0, 24 * 8 - 1), y(0, 6 * 8 - 1), z(-8, 2 * 8 - 1), cls(1, 20), inst(0, 3);
  for (int i = 0; i < 6000; ++i) g.set({x(rng), y(rng), z(rng)}, static_cast<uint8_t>(cls(rng)), static_cast<uint16_t>(inst(rng)));
  return g;
}

// The bricks of `g` whose brick x coordinate is in [x0, x1).
world::VoxelGrid slab(const world::VoxelGrid& g, int x0, int x1) {
  world::VoxelGrid s(g.origin(), g.voxel_size());
  for (const world::Brick& b : g.bricks())
    if (b.coord.x >= x0 && b.coord.x < x1) s.insert_brick(b);
  return s;
}

std::vector<uint64_t> keys_of(const world::VoxelGrid& g) {
  std::vector<uint64_t> k;
  for (const world::Brick& b : g.bricks()) k.push_back(world::brick_key(b.coord));
  return k;
}

void add_all(viewer::ResidentWorld& rw, const world::VoxelGrid& g, size_t slice) {
  std::vector<uint64_t> keys = keys_of(g);
  std::vector<uint32_t> recs(keys.size() * WORLD_BRICK_UINTS);
  for (size_t i = 0; i < g.bricks().size(); ++i) world::write_brick_record(g.bricks()[i], recs.data() + i * WORLD_BRICK_UINTS);
  for (size_t i = 0; i < keys.size(); i += slice) {
    const size_t n = std::min(slice, keys.size() - i);
    rw.add_static(keys.data() + i, recs.data() + i * WORLD_BRICK_UINTS, n);
    rw.commit();
  }
}

// Every voxel of the box (brick x in [0, 24), y in [0, 6), z in [-1, 2)) on a 3-voxel lattice, plus the car cells.
std::vector<glm::ivec3> queries(const std::vector<render::CarCell>& cars) {
  std::vector<glm::ivec3> q;
  for (int z = -8; z < 16; z += 1)
    for (int y = 0; y < 48; y += 3)
      for (int x = (z & 1); x < 192; x += 3) q.push_back({x, y, z});
  for (const render::CarCell& c : cars) q.push_back(c.ijk);
  return q;
}

size_t mismatches(gpu::Context& ctx, const world::GpuWorld& got_w, const world::GpuWorld& want_w,
                  const std::vector<glm::ivec3>& q) {
  const std::vector<world::Voxel> got = world::probe_gpu_world(ctx, got_w, q);
  const std::vector<world::Voxel> want = world::probe_gpu_world(ctx, want_w, q);
  size_t bad = 0;
  for (size_t i = 0; i < q.size(); ++i)
    if (got[i].class_id != want[i].class_id || got[i].instance != want[i].instance) {
      if (bad < 5)
        std::printf("  mismatch at (%d, %d, %d): got class %u inst %u, want class %u inst %u\n", q[i].x, q[i].y, q[i].z,
                    got[i].class_id, got[i].instance, want[i].class_id, want[i].instance);
      ++bad;
    }
  return bad;
}

std::vector<render::CarCell> car_cells(int x0, uint16_t inst) {
  std::vector<render::CarCell> c;
  for (int x = x0; x < x0 + 30; ++x)
    for (int y = 10; y < 25; ++y)
      for (int z = 0; z < 10; ++z) c.push_back({{x, y, z}, inst});
  return c;
}

}  // namespace

TEST_CASE("viewer resident world: slices, removals and overlays equal a world built from scratch") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid full = random_world(7);
  const world::VoxelGrid a = slab(full, 0, 14), b = slab(full, 8, 24);
  REQUIRE(a.brick_count() > 100);
  REQUIRE(b.brick_count() > 100);
  viewer::ResidentWorld rw(ctx, full.origin(), full.voxel_size(), std::max(a.brick_count(), b.brick_count()) + 3, 4);

  // Set a, added in slices of 37 bricks.
  add_all(rw, a, 37);
  CHECK(rw.static_bricks() == a.brick_count());
  const render::RaycastWorld ref_a = render::upload_raycast_world(ctx, a);
  CHECK(mismatches(ctx, rw.world().gpu, ref_a.gpu, queries({})) == 0);
  CHECK(rw.world().bounds.min == ref_a.bounds.min);
  CHECK(rw.world().bounds.max == ref_a.bounds.max);

  // Cars over both static and empty bricks (more bricks than the 4 overlay slots: the buffers grow).
  std::vector<render::CarCell> cars = car_cells(100, 5001);
  const std::vector<render::CarCell> more = car_cells(40, 5002);
  cars.insert(cars.end(), more.begin(), more.end());
  rw.set_overlay(cars);
  {
    render::OverlayWorld ow(ctx, a);
    ow.set_overlay(cars);
    CHECK(mismatches(ctx, rw.world().gpu, ow.world().gpu, queries(cars)) == 0);
    CHECK(rw.world().bounds.min == ow.world().bounds.min);
    CHECK(rw.world().bounds.max == ow.world().bounds.max);
  }

  // Move to set b while the cars stay: departed bricks first, then slices of 50, each committed.
  const uint64_t rev = rw.world().revision;
  std::vector<uint64_t> gone;
  for (const world::Brick& br : a.bricks())
    if (br.coord.x < 8) gone.push_back(world::brick_key(br.coord));
  rw.remove_static(gone);
  world::VoxelGrid added(full.origin(), full.voxel_size());
  for (const world::Brick& br : b.bricks())
    if (br.coord.x >= 14) added.insert_brick(br);
  add_all(rw, added, 50);
  CHECK(rw.world().revision > rev);
  CHECK(rw.static_bricks() == b.brick_count());
  {
    render::OverlayWorld ow(ctx, b);
    ow.set_overlay(cars);
    CHECK(mismatches(ctx, rw.world().gpu, ow.world().gpu, queries(cars)) == 0);
  }
  // The cars leave: exactly the static set b.
  rw.set_overlay({});
  const render::RaycastWorld ref_b = render::upload_raycast_world(ctx, b);
  CHECK(mismatches(ctx, rw.world().gpu, ref_b.gpu, queries(cars)) == 0);
  CHECK(rw.world().bounds.min == ref_b.bounds.min);
  CHECK(rw.world().bounds.max == ref_b.bounds.max);

  // More static bricks than slots: a clear error.
  std::vector<uint64_t> extra_keys;
  std::vector<uint32_t> extra_recs;
  for (int i = 0; i < 10; ++i) {
    extra_keys.push_back(world::brick_key({100 + i, 0, 0}));
    extra_recs.resize(extra_keys.size() * WORLD_BRICK_UINTS, 0u);
  }
  CHECK_THROWS_AS(rw.add_static(extra_keys.data(), extra_recs.data(), extra_keys.size()), std::length_error);
}
