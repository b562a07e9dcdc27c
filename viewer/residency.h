// Which parts of a large world live on the GPU (library icube_viewer_core).
//
// The world is cut into chunks: tile_m x tile_m tiles of the x-y plane (the
// same tiles as teleport.h's chunk targets; a brick belongs to the tile of its
// centre). With a residency radius R > 0 only the tiles whose rectangle comes
// within R of the camera (x-y) are on the GPU, in one persistent
// ResidentWorld (resident_world.h; the dynamic cars patched in as usual) with
// room for max_bricks static bricks (the brick records must fit one storage
// binding: kMaxResidentBricks · 1600 B < 128 MiB). When the camera has moved
// more than R/4 from where the resident set was chosen and the tiles within R
// differ, a background thread works out the change against the resident set
// (the full world is read-only meanwhile): the departed tiles' brick keys and
// the new tiles' brick records, nearest tiles first, the set capped at
// max_bricks (nearest first). The frame loop then applies it in slices between
// frames (swap(): the first slice frees the departed bricks; each slice
// writes at most step_bricks records, 4 MiB by default, and rebuilds and
// uploads the hash table once), so no frame stalls for a whole world's upload;
// the new tiles appear nearest first. The slices' main-thread times are
// recorded. R = 0: the whole world once.
// Tests: tests/viewer/test_viewer_residency.cpp, tests/viewer/test_viewer_resident_world.cpp.
#pragma once

#include "resident_world.h"
#include "world/voxel_grid.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <future>
#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace icube::viewer {

using TileKey = std::pair<int64_t, int64_t>;  // (i, j): x in [i·tile_m, (i+1)·tile_m)

// Brick records (WORLD_BRICK_UINTS · 4 = 1600 bytes) of the static world and the car overlay in one
// 128 MiB storage binding: 83,886 bricks; this leaves room for the overlay.
inline constexpr size_t kMaxResidentBricks = 80000;
// Brick records written per residency slice (4 MiB).
inline constexpr size_t kResidencyStepBricks = 2621;

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
  size_t swaps = 0;                                   // completed changes of the resident set (incl. the first)
  size_t steps = 0;                                   // slices applied between frames (swap(); not finish())
  double last_upload_ms = 0.0, max_upload_ms = 0.0;   // one slice on the main thread (max: swap()s only, the stalls)
  double last_build_ms = 0.0;                         // background: the change and its records
  size_t resident_bricks = 0;
  size_t last_added = 0, last_removed = 0, last_steps = 0;  // of the last completed change
  double last_max_step_ms = 0.0;                            // its slowest slice
};

class Residency {
 public:
  // `grid` must outlive this. radius_m <= 0: everything resident.
  Residency(gpu::Context& ctx, const world::VoxelGrid& grid, double radius_m, double tile_m = 51.2,
            size_t max_bricks = kMaxResidentBricks, size_t step_bricks = kResidencyStepBricks);
  ~Residency();
  Residency(const Residency&) = delete;
  Residency& operator=(const Residency&) = delete;

  // Called every frame with the camera's x-y: starts a background rebuild when needed.
  void update(const glm::dvec2& camera_xy);
  // True when a computed change has slices left to apply (the caller waits for the GPU first, then calls swap()).
  bool ready() const;
  // Applies the next slice of the change (at most step_bricks records; the car overlay is kept).
  void swap();
  // Blocks until the pending change (if any) is computed and applies all of it (scripted runs, tests).
  void finish();

  ResidentWorld& world() { return *world_; }
  double radius() const { return radius_; }
  const ChunkIndex& index() const { return index_; }
  bool resident(const TileKey& k) const;
  bool pending() const { return pending_.valid() || transit_.has_value(); }
  const ResidencyStats& stats() const { return stats_; }

 private:
  struct Built {
    std::vector<TileKey> keys;           // the new resident set, sorted
    std::vector<uint64_t> removed;       // brick keys of the departed tiles
    std::vector<uint64_t> added;         // brick keys of the new tiles, nearest tiles first
    std::vector<uint32_t> records;       // their records, WORLD_BRICK_UINTS each
    double build_ms = 0.0;
  };
  Built change(const std::vector<TileKey>& have, const std::vector<TileKey>& want, const glm::dvec2& xy) const;
  void step(size_t max_bricks, bool frame_slice);  // frame_slice: a swap() between frames (its time is a stall)
  gpu::Context& ctx_;
  const world::VoxelGrid& grid_;
  double radius_;
  size_t max_bricks_, step_bricks_;
  ChunkIndex index_;
  std::unique_ptr<ResidentWorld> world_;
  std::vector<TileKey> keys_;  // resident, sorted
  glm::dvec2 centre_{0.0};
  bool have_centre_ = false;
  std::future<Built> pending_;
  std::optional<Built> transit_;       // being applied
  size_t next_ = 0, transit_steps_ = 0;
  double transit_max_ms_ = 0.0;
  ResidencyStats stats_;
};

}  // namespace icube::viewer
