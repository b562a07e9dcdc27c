// Static GPU world + per-frame brick overlay; see overlay_world.h.
#include "render/buffers/overlay_world.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstring>
#include <map>
#include <stdexcept>

namespace icube::render {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

constexpr shader::WorldHashEntry kEmpty{0, 0, WORLD_EMPTY_SLOT, 0};


}  // namespace

OverlayWorld::OverlayWorld(gpu::Context& ctx, const world::VoxelGrid& g, size_t overlay_capacity) : ctx_(ctx) {
  const world::GpuWorldHost h = world::build_gpu_world_host(g);
  static_records_ = h.bricks;
  static_count_ = h.brick_count;
  for (uint32_t idx : g.sorted_brick_order()) static_keys_.push_back(world::brick_key(g.bricks()[idx].coord));
  if (static_keys_.size() != static_count_) throw std::logic_error("OverlayWorld: brick order differs from the host world");
  static_bounds_ = raycast_bounds(g);
  world_.gpu.origin = g.origin();
  world_.gpu.voxel_size = g.voxel_size();
  allocate(std::max<size_t>(overlay_capacity, 1));
}

void OverlayWorld::allocate(size_t cap) {
  capacity_ = cap;
  const size_t total = static_count_ + cap;
  const uint64_t slots = std::bit_ceil(std::max<uint64_t>(2, 2 * static_cast<uint64_t>(total)));
  if (slots > (uint64_t{1} << 31)) throw std::length_error("OverlayWorld: world too large for the hash table");
  table_.assign(slots, kEmpty);
  const uint32_t mask = static_cast<uint32_t>(slots - 1);
  world_.gpu.table_mask = mask;
  for (size_t b = 0; b < static_count_; ++b) {
    const uint64_t key = static_keys_[b];
    uint32_t s = world::brick_key_hash(key) & mask;
    while (table_[s].brick != WORLD_EMPTY_SLOT) s = (s + 1) & mask;
    table_[s] = {static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32), static_cast<uint32_t>(b), 0};
  }
  dirty_.clear();
  const size_t rec_bytes = WORLD_BRICK_UINTS * sizeof(uint32_t);
  world_.gpu.brick_data = gpu::Buffer(ctx_, total * rec_bytes, gpu::MemoryUsage::DeviceLocal, "overlay-brick-data");
  world_.gpu.brick_table =
      gpu::Buffer(ctx_, table_.size() * sizeof(shader::WorldHashEntry), gpu::MemoryUsage::DeviceLocal, "overlay-brick-table");
  world_.gpu.brick_count = static_cast<uint32_t>(total);
  // The overlay slots start zeroed (never read until a table entry points at them).
  std::vector<uint32_t> init(total * WORLD_BRICK_UINTS, 0);
  std::copy(static_records_.begin(), static_records_.end(), init.begin());
  gpu::upload(ctx_, world_.gpu.brick_data, init.data(), init.size() * sizeof(uint32_t));
  gpu::upload(ctx_, world_.gpu.brick_table, table_.data(), table_.size() * sizeof(shader::WorldHashEntry));
  static_bytes_ = init.size() * sizeof(uint32_t) + table_.size() * sizeof(shader::WorldHashEntry);
  world_.bounds = static_bounds_;
  // Its own id, so the ray caster keeps the occupancy masks while no car changes (raycast_gpu.h).
  world_.id = new_raycast_world_id();
  ++world_.revision;
}

uint32_t OverlayWorld::find_slot(uint64_t key) const { return world::find_table_slot(table_, world_.gpu.table_mask, key); }

std::map<uint64_t, std::vector<const CarCell*>> car_cells_by_brick(const std::vector<CarCell>& cells) {
  std::map<uint64_t, std::vector<const CarCell*>> by_brick;
  for (const CarCell& c : cells) {
    if (!world::ijk_in_range(c.ijk)) continue;
    by_brick[world::brick_key(world::brick_of(c.ijk))].push_back(&c);
  }
  return by_brick;
}

void paint_car_cells(uint32_t* rec, const std::vector<const CarCell*>& cells, OverlayStats& st) {
  for (const CarCell* c : cells) {
    const world::Voxel old = world::record_voxel(rec, c->ijk);
    if (old.class_id == static_cast<uint8_t>(world::SemanticClass::Car) && old.instance > 0) continue;
    world::record_set_voxel(rec, c->ijk, static_cast<uint8_t>(world::SemanticClass::Car), c->instance);
    ++st.cells;
  }
}

OverlayStats OverlayWorld::set_overlay(const std::vector<CarCell>& cells) {
  const auto t0 = Clock::now();
  OverlayStats st;
  const bool had_overlay = !dirty_.empty();
  const std::map<uint64_t, std::vector<const CarCell*>> by_brick = car_cells_by_brick(cells);
  if (by_brick.size() > capacity_) allocate(std::max(by_brick.size(), 2 * capacity_));
  // Restore the previous frame's entries (in reverse, so a slot dirtied twice ends at its static value).
  for (auto it = dirty_.rbegin(); it != dirty_.rend(); ++it) table_[it->first] = it->second;
  dirty_.clear();
  world::IjkBounds bounds = static_bounds_;
  std::vector<uint32_t> records(by_brick.size() * WORLD_BRICK_UINTS, 0);
  size_t slot_index = 0;
  for (const auto& [key, list] : by_brick) {
    uint32_t* rec = records.data() + slot_index * WORLD_BRICK_UINTS;
    const uint32_t s = find_slot(key);
    const bool exists = table_[s].brick != WORLD_EMPTY_SLOT;
    if (exists)
      std::memcpy(rec, static_records_.data() + size_t{table_[s].brick} * WORLD_BRICK_UINTS,
                  WORLD_BRICK_UINTS * sizeof(uint32_t));
    else
      ++st.new_bricks;
    paint_car_cells(rec, list, st);
    dirty_.push_back({s, table_[s]});
    table_[s] = {static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32),
                 static_cast<uint32_t>(static_count_ + slot_index), 0};
    world::join_brick_bounds(bounds, key);
    ++slot_index;
  }
  st.bricks = by_brick.size();
  world_.bounds = bounds;
  st.build_s = seconds_since(t0);
  const auto t1 = Clock::now();
  const size_t rec_bytes = records.size() * sizeof(uint32_t);
  if (rec_bytes)
    gpu::upload(ctx_, world_.gpu.brick_data, records.data(), rec_bytes,
                static_count_ * WORLD_BRICK_UINTS * sizeof(uint32_t));
  const size_t table_bytes = table_.size() * sizeof(shader::WorldHashEntry);
  if (had_overlay || !by_brick.empty()) {  // nothing changed when both frames have no cars
    gpu::upload(ctx_, world_.gpu.brick_table, table_.data(), table_bytes);
    st.uploaded_bytes = rec_bytes + table_bytes;
  }
  if (rec_bytes || had_overlay || !by_brick.empty()) ++world_.revision;  // bricks or bounds changed: new masks
  st.upload_s = seconds_since(t1);
  return st;
}

}  // namespace icube::render
