// Outpainting's latent store (engine/diffusion/latent_store.h): in trajectory
// mode a chunk 38.4 m ahead along x reads the previous chunk's last 16 x-cells
// (12.8 m of overlap) shifted by exactly 48 cells, a quarter-turned chunk reads
// them rotated, a chunk far away reads nothing; in blocks mode the first
// writer of a world cell wins and a block reads its neighbours' overlap.
#include <doctest/doctest.h>

#include "diffusion/latent_store.h"

using namespace icube;
using namespace icube::diffusion;

namespace {

constexpr size_t kCells = 64 * 64 * 64;

world::ChunkPose pose_at(double x, double y, double z, double yaw_deg = 0.0) {
  const double a = yaw_deg * 3.14159265358979323846 / 180.0;
  world::ChunkPose p;
  p.chunk_to_world = glm::dmat4(glm::dvec4(std::cos(a), std::sin(a), 0, 0), glm::dvec4(-std::sin(a), std::cos(a), 0, 0),
                                glm::dvec4(0, 0, 1, 0), glm::dvec4(x, y, z, 1));
  return p;
}

size_t idx(int i, int j, int k) { return (static_cast<size_t>(i + 32) * 64 + static_cast<size_t>(j + 32)) * 64 + static_cast<size_t>(k + 32); }

// Channel c of cell (i, j, k) holds a code of the cell.
std::vector<float> coded_latent(float tag) {
  std::vector<float> v(2 * kCells);
  for (int i = -32; i < 32; ++i)
    for (int j = -32; j < 32; ++j)
      for (int k = -32; k < 32; ++k) {
        v[idx(i, j, k)] = tag + static_cast<float>(i * 10000 + j * 100 + k);
        v[kCells + idx(i, j, k)] = -tag;
      }
  return v;
}

size_t count(const KnownLatents& k) {
  size_t n = 0;
  for (const uint32_t m : k.mask) n += m;
  return n;
}

}  // namespace

TEST_CASE("latent store: trajectory mode maps the previous chunk's cells to the nearest cells of the new frame") {
  LatentStore store(world::PlanMode::Trajectory, 2);
  CHECK_FALSE(store.known_for(pose_at(0, 0, 0)).any());
  store.add(pose_at(100, 200, 5), coded_latent(0.25f));
  const KnownLatents k = store.known_for(pose_at(100 + 38.4, 200, 5));
  CHECK(count(k) == 16 * 64 * 64);  // 12.8 m / 0.8 m = 16 cells of overlap along x
  CHECK(k.mask[idx(-32, 5, 3)] == 1);
  CHECK(k.values[idx(-32, 5, 3)] == 0.25f + 16 * 10000 + 5 * 100 + 3);  // new i = old i - 48
  CHECK(k.values[kCells + idx(-17, 0, 0)] == -0.25f);
  CHECK(k.mask[idx(-16, 0, 0)] == 0);
  // A quarter turn about the same centre: new (i', j') = (j, -1 - i), so new (3, 7) reads old (-8, 3).
  const KnownLatents r = store.known_for(pose_at(100, 200, 5, 90.0));
  CHECK(count(r) == kCells);
  CHECK(r.values[idx(3, 7, 1)] == 0.25f - 8 * 10000 + 3 * 100 + 1);
  CHECK_FALSE(store.known_for(pose_at(1000, 0, 0)).any());
  // Only the previous chunk is kept.
  store.add(pose_at(500, 0, 0), coded_latent(0.5f));
  CHECK_FALSE(store.known_for(pose_at(100 + 38.4, 200, 5)).any());
  CHECK_THROWS_AS(store.add(pose_at(0, 0, 0), std::vector<float>(10)), std::invalid_argument);
}

TEST_CASE("latent store: blocks mode keeps every cell by world latent ijk, first writer wins") {
  LatentStore store(world::PlanMode::Blocks, 2);
  const double x0 = 12.3, y0 = -7.7, z0 = 4.0;
  store.add(pose_at(x0, y0, z0), coded_latent(0.0f));
  store.add(pose_at(x0 + 38.4, y0, z0), coded_latent(0.5f));  // overlaps the first by 16 x-cells: the first's stay
  const KnownLatents k = store.known_for(pose_at(x0 + 38.4, y0 + 38.4, z0));
  CHECK(count(k) == 16 * 64 * 64);  // its y overlap with the second block
  CHECK(k.values[idx(0, -32, 0)] == 0.5f + 0 * 10000 + 16 * 100 + 0);
  // The corner it shares with the first block too: the first block's value (first writer).
  CHECK(k.values[idx(-32, -32, 0)] == 0.0f + 16 * 10000 + 16 * 100 + 0);
  // z off the lattice: nearest cells, still the whole overlap.
  CHECK(count(store.known_for(pose_at(x0 + 76.8, y0, z0 + 0.13))) == 16 * 64 * 64);
}
