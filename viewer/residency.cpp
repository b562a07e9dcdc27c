// GPU residency of a large world's chunks; see residency.h.
#include "residency.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace icube::viewer {

ChunkIndex::ChunkIndex(const world::VoxelGrid& grid, double tile_m) : tile_m_(tile_m) {
  const std::vector<world::Brick>& bricks = grid.bricks();
  const double vs = grid.voxel_size();
  for (uint32_t b = 0; b < bricks.size(); ++b) {
    const glm::dvec3 c = grid.origin() + (glm::dvec3(bricks[b].coord) * 8.0 + 4.0) * vs;
    tiles_[{static_cast<int64_t>(std::floor(c.x / tile_m)), static_cast<int64_t>(std::floor(c.y / tile_m))}].push_back(b);
  }
}

std::vector<TileKey> ChunkIndex::tiles_within(const glm::dvec2& xy, double radius, size_t max_bricks) const {
  std::vector<std::pair<double, TileKey>> near;
  for (const auto& [k, bricks] : tiles_) {
    const double x0 = static_cast<double>(k.first) * tile_m_, y0 = static_cast<double>(k.second) * tile_m_;
    const double dx = std::max({x0 - xy.x, 0.0, xy.x - (x0 + tile_m_)});
    const double dy = std::max({y0 - xy.y, 0.0, xy.y - (y0 + tile_m_)});
    const double d2 = dx * dx + dy * dy;
    if (d2 <= radius * radius) {
      const double cx = x0 + 0.5 * tile_m_ - xy.x, cy = y0 + 0.5 * tile_m_ - xy.y;
      near.push_back({d2 + 1e-6 * (cx * cx + cy * cy), k});  // ties (the camera's own tiles): by centre distance
    }
  }
  std::sort(near.begin(), near.end());
  std::vector<TileKey> out;
  size_t total = 0;
  for (const auto& [d, k] : near) {
    const size_t n = tiles_.at(k).size();
    if (total + n > max_bricks) break;
    total += n;
    out.push_back(k);
  }
  std::sort(out.begin(), out.end());
  return out;
}

world::VoxelGrid ChunkIndex::subset(const world::VoxelGrid& grid, const std::vector<TileKey>& keys) const {
  world::VoxelGrid g(grid.origin(), grid.voxel_size());
  for (const TileKey& k : keys) {
    const auto it = tiles_.find(k);
    if (it == tiles_.end()) continue;
    for (uint32_t b : it->second) g.insert_brick(grid.bricks()[b]);
  }
  return g;
}

Residency::Residency(gpu::Context& ctx, const world::VoxelGrid& grid, double radius_m, double tile_m, size_t max_bricks)
    : ctx_(ctx), grid_(grid), radius_(radius_m), max_bricks_(max_bricks), index_(grid, tile_m) {
  if (radius_ <= 0.0) {
    world_ = std::make_unique<render::OverlayWorld>(ctx_, grid_);
    for (const auto& [k, b] : index_.tiles()) keys_.push_back(k);
    stats_.resident_bricks = grid_.brick_count();
  }
}

Residency::~Residency() {
  if (pending_.valid()) pending_.wait();
}

void Residency::update(const glm::dvec2& xy) {
  if (radius_ <= 0.0 || pending_.valid()) return;
  if (have_centre_ && glm::length(xy - centre_) <= 0.25 * radius_) return;
  std::vector<TileKey> want = index_.tiles_within(xy, radius_, max_bricks_);
  centre_ = xy;
  have_centre_ = true;
  if (want == keys_ && world_) return;
  pending_ = std::async(std::launch::async, [this, want = std::move(want)]() {
    const auto t0 = std::chrono::steady_clock::now();
    Built b;
    b.keys = want;
    b.grid = index_.subset(grid_, want);
    b.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return b;
  });
  if (!world_) finish();  // the first set: nothing to show meanwhile
}

bool Residency::ready() const {
  return pending_.valid() && pending_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

void Residency::swap() {
  if (!pending_.valid()) return;
  Built b = pending_.get();
  const auto t0 = std::chrono::steady_clock::now();
  world_ = std::make_unique<render::OverlayWorld>(ctx_, b.grid);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  keys_ = std::move(b.keys);
  ++stats_.swaps;
  stats_.last_upload_ms = ms;
  stats_.max_upload_ms = std::max(stats_.max_upload_ms, ms);
  stats_.last_build_ms = b.build_ms;
  stats_.resident_bricks = b.grid.brick_count();
}

void Residency::finish() {
  if (!pending_.valid()) return;
  pending_.wait();
  swap();
}

bool Residency::resident(const TileKey& k) const { return std::binary_search(keys_.begin(), keys_.end(), k); }

}  // namespace icube::viewer
