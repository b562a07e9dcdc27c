// Which parts of a large world live on the GPU (library icube_viewer_core).
//
// The world is cut into chunks: tile_m x tile_m tiles of the x-y plane (the
// same tiles as teleport.h's chunk targets; a brick belongs to the tile of its
// centre). With a residency radius R > 0 only the tiles whose rectangle comes
// within R of the camera (x-y) are on the GPU, as a render::OverlayWorld of
// their bricks (the dynamic cars patched in as usual). When the camera has
// moved more than R/4 from where the resident set was chosen and the tiles
// within R differ, a background thread copies the new set's bricks into a
// VoxelGrid (CPU only; the full world is read-only meanwhile), nearest tiles
// first up to max_bricks (the brick records must fit one storage binding:
// kMaxResidentBricks · 1600 B < 128 MiB); the frame loop
// polls it and swaps in the new GPU world (the upload, on the main thread,
// is the only stall; its time is recorded). R = 0: the whole world once.
// Tests: tests/test_viewer_residency.cpp.
#pragma once

#include "render/buffers/overlay_world.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <future>
#include <map>
#include <memory>
#include <utility>
#include <vector>

namespace icube::viewer {

using TileKey = std::pair<int64_t, int64_t>;  // (i, j): x in [i·tile_m, (i+1)·tile_m)

// Brick records (WORLD_BRICK_UINTS · 4 = 1600 bytes) of the static world and the car overlay in one
// 128 MiB storage binding: 83,886 bricks; this leaves room for the overlay.
inline constexpr size_t kMaxResidentBricks = 80000;

// The bricks of each tile.
class ChunkIndex {
 public:
  ChunkIndex(const world::VoxelGrid& grid, double tile_m);
  double tile_m() const { return tile_m_; }
  const std::map<TileKey, std::vector<uint32_t>>& tiles() const { return tiles_; }
  // Tiles whose rectangle is within `radius` of xy (x-y distance), nearest first while their
  // bricks add up to at most max_bricks; returned sorted by key.
  std::vector<TileKey> tiles_within(const glm::dvec2& xy, double radius, size_t max_bricks = SIZE_MAX) const;
  // A grid holding exactly the bricks of `keys` (same origin and voxel size).
  world::VoxelGrid subset(const world::VoxelGrid& grid, const std::vector<TileKey>& keys) const;

 private:
  double tile_m_;
  std::map<TileKey, std::vector<uint32_t>> tiles_;
};

struct ResidencyStats {
  size_t swaps = 0;
  double last_upload_ms = 0.0, max_upload_ms = 0.0;
  double last_build_ms = 0.0;  // background brick copy
  size_t resident_bricks = 0;
};

class Residency {
 public:
  // `grid` must outlive this. radius_m <= 0: everything resident.
  Residency(gpu::Context& ctx, const world::VoxelGrid& grid, double radius_m, double tile_m = 51.2,
            size_t max_bricks = kMaxResidentBricks);
  ~Residency();
  Residency(const Residency&) = delete;
  Residency& operator=(const Residency&) = delete;

  // Called every frame with the camera's x-y: starts a background rebuild when needed.
  void update(const glm::dvec2& camera_xy);
  // True when a rebuilt set is ready to swap in (the caller waits for the GPU first, then calls swap()).
  bool ready() const;
  // Uploads the ready set and replaces the GPU world; the caller re-applies its car overlay.
  void swap();
  // Blocks until the pending rebuild (if any) is done and swaps it in (scripted runs, tests).
  void finish();

  render::OverlayWorld& world() { return *world_; }
  double radius() const { return radius_; }
  const ChunkIndex& index() const { return index_; }
  bool resident(const TileKey& k) const;
  bool pending() const { return pending_.valid(); }
  const ResidencyStats& stats() const { return stats_; }

 private:
  struct Built {
    std::vector<TileKey> keys;
    world::VoxelGrid grid;
    double build_ms = 0.0;
  };
  gpu::Context& ctx_;
  const world::VoxelGrid& grid_;
  double radius_;
  size_t max_bricks_;
  ChunkIndex index_;
  std::unique_ptr<render::OverlayWorld> world_;
  std::vector<TileKey> keys_;  // resident, sorted
  glm::dvec2 centre_{0.0};
  bool have_centre_ = false;
  std::future<Built> pending_;
  ResidencyStats stats_;
};

}  // namespace icube::viewer
