// GPU residency of a large world's chunks; see residency.h.
#include "residency.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "world/gpu_world.h"

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

Residency::Residency(gpu::Context& ctx, const world::VoxelGrid& grid, double radius_m, double tile_m, size_t max_bricks,
                     size_t step_bricks)
    : ctx_(ctx),
      grid_(grid),
      radius_(radius_m),
      max_bricks_(max_bricks),
      step_bricks_(std::max<size_t>(step_bricks, 1)),
      index_(grid, tile_m) {
  const size_t capacity = radius_ <= 0.0 ? grid_.brick_count() : std::min(max_bricks_, grid_.brick_count());
  world_ = std::make_unique<ResidentWorld>(ctx_, grid_.origin(), grid_.voxel_size(), capacity);
  if (radius_ <= 0.0) {
    std::vector<TileKey> all;
    for (const auto& [k, b] : index_.tiles()) all.push_back(k);
    pending_ = std::async(std::launch::deferred, [this, all]() { return change({}, all, glm::dvec2(0.0)); });
    finish();
  }
}

Residency::~Residency() {
  if (pending_.valid()) pending_.wait();
}

Residency::Built Residency::change(const std::vector<TileKey>& have, const std::vector<TileKey>& want,
                                   const glm::dvec2& xy) const {
  const auto t0 = std::chrono::steady_clock::now();
  Built b;
  b.keys = want;
  const std::vector<world::Brick>& bricks = grid_.bricks();
  for (const TileKey& k : have)
    if (!std::binary_search(want.begin(), want.end(), k))
      for (uint32_t i : index_.tiles().at(k)) b.removed.push_back(world::brick_key(bricks[i].coord));
  std::vector<std::pair<double, TileKey>> added;
  for (const TileKey& k : want)
    if (!std::binary_search(have.begin(), have.end(), k)) {
      const double cx = (static_cast<double>(k.first) + 0.5) * index_.tile_m() - xy.x;
      const double cy = (static_cast<double>(k.second) + 0.5) * index_.tile_m() - xy.y;
      added.push_back({cx * cx + cy * cy, k});
    }
  std::sort(added.begin(), added.end());
  size_t n = 0;
  for (const auto& [d, k] : added) n += index_.tiles().at(k).size();
  b.added.reserve(n);
  b.records.resize(n * WORLD_BRICK_UINTS);
  for (const auto& [d, k] : added)
    for (uint32_t i : index_.tiles().at(k)) {
      world::write_brick_record(bricks[i], b.records.data() + b.added.size() * WORLD_BRICK_UINTS);
      b.added.push_back(world::brick_key(bricks[i].coord));
    }
  b.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

void Residency::update(const glm::dvec2& xy) {
  if (radius_ <= 0.0 || pending()) return;
  if (have_centre_ && glm::length(xy - centre_) <= 0.25 * radius_) return;
  std::vector<TileKey> want = index_.tiles_within(xy, radius_, max_bricks_);
  const bool first = !have_centre_;
  centre_ = xy;
  have_centre_ = true;
  if (want == keys_ && !first) return;
  pending_ = std::async(std::launch::async, [this, have = keys_, want = std::move(want), xy]() {
    return change(have, want, xy);
  });
  if (first) finish();  // the first set: nothing to show meanwhile
}

bool Residency::ready() const {
  return transit_.has_value() ||
         (pending_.valid() && pending_.wait_for(std::chrono::seconds(0)) == std::future_status::ready);
}

void Residency::step(size_t max_bricks, bool frame_slice) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!transit_) {
    if (!pending_.valid()) return;
    transit_ = pending_.get();
    next_ = 0;
    transit_steps_ = 0;
    transit_max_ms_ = 0.0;
    world_->remove_static(transit_->removed);  // freed before any new record needs the room
  }
  const size_t total = transit_->added.size();
  const size_t n = std::min(max_bricks, total - next_);
  world_->add_static(transit_->added.data() + next_, transit_->records.data() + next_ * WORLD_BRICK_UINTS, n);
  next_ += n;
  world_->commit();
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (frame_slice) ++stats_.steps;
  ++transit_steps_;
  stats_.last_upload_ms = ms;
  if (frame_slice) {
    stats_.max_upload_ms = std::max(stats_.max_upload_ms, ms);
    transit_max_ms_ = std::max(transit_max_ms_, ms);
  }
  stats_.resident_bricks = world_->static_bricks();
  if (next_ < total) return;
  keys_ = std::move(transit_->keys);
  ++stats_.swaps;
  stats_.last_build_ms = transit_->build_ms;
  stats_.last_added = total;
  stats_.last_removed = transit_->removed.size();
  stats_.last_steps = transit_steps_;
  stats_.last_max_step_ms = transit_max_ms_;
  transit_.reset();
}

void Residency::swap() { step(step_bricks_, true); }

void Residency::finish() {
  while (pending()) step(SIZE_MAX, false);
}

bool Residency::resident(const TileKey& k) const { return std::binary_search(keys_.begin(), keys_.end(), k); }

}  // namespace icube::viewer
