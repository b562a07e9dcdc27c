// A persistent GPU world updated brick by brick; see resident_world.h.
#include "resident_world.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>

namespace icube::viewer {

namespace {

constexpr uint64_t kFree = ~uint64_t{0};
constexpr shader::WorldHashEntry kEmpty{0, 0, WORLD_EMPTY_SLOT, 0};
constexpr size_t kRecordBytes = WORLD_BRICK_UINTS * sizeof(uint32_t);

}  // namespace

ResidentWorld::ResidentWorld(gpu::Context& ctx, const glm::dvec3& origin, double voxel_size, size_t static_capacity,
                             size_t overlay_capacity)
    : ctx_(ctx), static_capacity_(std::max<size_t>(static_capacity, 1)) {
  records_.assign(static_capacity_ * WORLD_BRICK_UINTS, 0u);
  key_of_.assign(static_capacity_, kFree);
  free_.resize(static_capacity_);
  for (size_t s = 0; s < static_capacity_; ++s) free_[s] = static_cast<uint32_t>(static_capacity_ - 1 - s);
  world_.gpu.origin = origin;
  world_.gpu.voxel_size = voxel_size;
  world_.id = render::new_raycast_world_id();  // cached occupancy masks while nothing changes
  allocate(std::max<size_t>(overlay_capacity, 1));
}

void ResidentWorld::allocate(size_t overlay_capacity) {
  overlay_capacity_ = overlay_capacity;
  const size_t total = static_capacity_ + overlay_capacity_;
  if (total * kRecordBytes > ctx_.info().max_storage_buffer_range)
    throw std::length_error("resident world: " + std::to_string(total) + " brick records pass one storage binding (" +
                            std::to_string(ctx_.info().max_storage_buffer_range / kRecordBytes) + ")");
  const uint64_t slots = std::bit_ceil(std::max<uint64_t>(2, 2 * static_cast<uint64_t>(total)));
  if (slots > (uint64_t{1} << 31)) throw std::length_error("resident world: too large for the hash table");
  world_.gpu.table_mask = static_cast<uint32_t>(slots - 1);
  world_.gpu.brick_count = static_cast<uint32_t>(total);
  world_.gpu.brick_data = gpu::Buffer(ctx_, total * kRecordBytes, gpu::MemoryUsage::DeviceLocal, "resident-brick-data");
  world_.gpu.brick_table =
      gpu::Buffer(ctx_, slots * sizeof(shader::WorldHashEntry), gpu::MemoryUsage::DeviceLocal, "resident-brick-table");
  // Resident records (re-)uploaded in runs of occupied slots; free and overlay slots are never read unreferenced.
  for (size_t s = 0; s < static_capacity_;) {
    if (key_of_[s] == kFree) {
      ++s;
      continue;
    }
    size_t e = s;
    while (e < static_capacity_ && key_of_[e] != kFree) ++e;
    gpu::upload(ctx_, world_.gpu.brick_data, records_.data() + s * WORLD_BRICK_UINTS, (e - s) * kRecordBytes,
                s * kRecordBytes);
    s = e;
  }
  rebuild_ = true;  // the table's size may have changed
  commit();
}

void ResidentWorld::remove_static(const std::vector<uint64_t>& keys) {
  for (uint64_t k : keys) {
    const auto it = slot_of_.find(k);
    if (it == slot_of_.end()) continue;
    key_of_[it->second] = kFree;
    free_.push_back(it->second);
    slot_of_.erase(it);
    rebuild_ = true;  // linear probing: entries are removed by rebuilding the table
  }
  std::sort(free_.begin(), free_.end(), std::greater<>());
}

void ResidentWorld::add_static(const uint64_t* keys, const uint32_t* records, size_t n) {
  last_bytes_ = 0;
  size_t fresh = 0;
  for (size_t i = 0; i < n; ++i) fresh += slot_of_.count(keys[i]) ? 0 : 1;
  if (fresh > free_.size())
    throw std::length_error("resident world: " + std::to_string(slot_of_.size() + fresh) + " static bricks pass its " +
                            std::to_string(static_capacity_) + " slots");
  std::vector<uint32_t> slot(n);
  for (size_t i = 0; i < n; ++i) {
    const auto it = slot_of_.find(keys[i]);
    if (it != slot_of_.end()) {
      slot[i] = it->second;
      continue;
    }
    slot[i] = free_.back();
    free_.pop_back();
    key_of_[slot[i]] = keys[i];
    slot_of_[keys[i]] = slot[i];
    added_.push_back(slot[i]);
  }
  // Host copies, then one upload per run of consecutive slots holding consecutive inputs.
  for (size_t i = 0; i < n; ++i)
    std::memcpy(records_.data() + size_t{slot[i]} * WORLD_BRICK_UINTS, records + i * WORLD_BRICK_UINTS, kRecordBytes);
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && slot[j] == slot[j - 1] + 1) ++j;
    gpu::upload(ctx_, world_.gpu.brick_data, records + i * WORLD_BRICK_UINTS, (j - i) * kRecordBytes,
                size_t{slot[i]} * kRecordBytes);
    last_bytes_ += (j - i) * kRecordBytes;
    i = j;
  }
}

void ResidentWorld::rebuild_static_table() {
  table_.assign(size_t{world_.gpu.table_mask} + 1, kEmpty);
  static_bounds_ = {};
  for (size_t s = 0; s < static_capacity_; ++s) {
    const uint64_t key = key_of_[s];
    if (key == kFree) continue;
    const uint32_t t = world::find_table_slot(table_, world_.gpu.table_mask, key);  // keys are unique: an empty slot
    table_[t] = {static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32), static_cast<uint32_t>(s), 0};
    world::join_brick_bounds(static_bounds_, key);
  }
  dirty_.clear();
}

void ResidentWorld::commit() {
  if (rebuild_ || table_.empty()) {
    rebuild_static_table();
  } else {
    // Only additions: back to the static table, then insert the new entries.
    for (auto it = dirty_.rbegin(); it != dirty_.rend(); ++it) table_[it->first] = it->second;
    dirty_.clear();
    for (uint32_t s : added_) {
      const uint64_t key = key_of_[s];
      const uint32_t t = world::find_table_slot(table_, world_.gpu.table_mask, key);  // a new key: an empty slot
      table_[t] = {static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32), s, 0};
      world::join_brick_bounds(static_bounds_, key);
    }
  }
  rebuild_ = false;
  added_.clear();
  const render::OverlayStats st = patch_overlay();
  last_bytes_ = st.uploaded_bytes;
  if (!st.uploaded_bytes) {  // no cars: the table was not uploaded by the patch
    gpu::upload(ctx_, world_.gpu.brick_table, table_.data(), table_.size() * sizeof(shader::WorldHashEntry));
    last_bytes_ += table_.size() * sizeof(shader::WorldHashEntry);
  }
  world_.bounds = st.bricks ? world_.bounds : static_bounds_;
  ++world_.revision;
}

uint32_t ResidentWorld::find_slot(uint64_t key) const { return world::find_table_slot(table_, world_.gpu.table_mask, key); }

render::OverlayStats ResidentWorld::set_overlay(const std::vector<render::CarCell>& cells) {
  const bool had = !cells_.empty();
  cells_ = cells;
  // Restore the previous overlay's entries (in reverse, so a slot dirtied twice ends at its static value).
  for (auto it = dirty_.rbegin(); it != dirty_.rend(); ++it) table_[it->first] = it->second;
  dirty_.clear();
  render::OverlayStats st = patch_overlay();
  if (had && !st.uploaded_bytes) {  // the cars left: the static table again
    gpu::upload(ctx_, world_.gpu.brick_table, table_.data(), table_.size() * sizeof(shader::WorldHashEntry));
    st.uploaded_bytes = table_.size() * sizeof(shader::WorldHashEntry);
    world_.bounds = static_bounds_;
  }
  if (st.uploaded_bytes) ++world_.revision;  // bricks or bounds changed: new masks
  last_bytes_ = st.uploaded_bytes;
  return st;
}

render::OverlayStats ResidentWorld::patch_overlay() {
  const auto t0 = std::chrono::steady_clock::now();
  render::OverlayStats st;
  const std::map<uint64_t, std::vector<const render::CarCell*>> by_brick = render::car_cells_by_brick(cells_);
  if (by_brick.empty()) return st;
  if (by_brick.size() > overlay_capacity_) {
    allocate(std::max(by_brick.size(), 2 * overlay_capacity_));  // re-uploads everything and re-patches through commit()
    st.bricks = by_brick.size();
    st.uploaded_bytes = last_bytes_;
    return st;
  }
  world::IjkBounds bounds = static_bounds_;
  std::vector<uint32_t> recs(by_brick.size() * WORLD_BRICK_UINTS, 0u);
  size_t k = 0;
  for (const auto& [key, list] : by_brick) {
    uint32_t* rec = recs.data() + k * WORLD_BRICK_UINTS;
    const uint32_t s = find_slot(key);
    if (table_[s].brick != WORLD_EMPTY_SLOT)
      std::memcpy(rec, records_.data() + size_t{table_[s].brick} * WORLD_BRICK_UINTS, kRecordBytes);
    else
      ++st.new_bricks;
    render::paint_car_cells(rec, list, st);
    dirty_.push_back({s, table_[s]});
    table_[s] = {static_cast<uint32_t>(key), static_cast<uint32_t>(key >> 32),
                 static_cast<uint32_t>(static_capacity_ + k), 0};
    world::join_brick_bounds(bounds, key);
    ++k;
  }
  st.bricks = by_brick.size();
  world_.bounds = bounds;
  st.build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto t1 = std::chrono::steady_clock::now();
  gpu::upload(ctx_, world_.gpu.brick_data, recs.data(), recs.size() * sizeof(uint32_t), static_capacity_ * kRecordBytes);
  gpu::upload(ctx_, world_.gpu.brick_table, table_.data(), table_.size() * sizeof(shader::WorldHashEntry));
  st.uploaded_bytes = recs.size() * sizeof(uint32_t) + table_.size() * sizeof(shader::WorldHashEntry);
  st.upload_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  return st;
}

}  // namespace icube::viewer
