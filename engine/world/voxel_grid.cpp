// VoxelGrid: sparse 8^3 bricks behind a hash map on the packed brick coordinate.
#include "world/voxel_grid.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>

namespace icube::world {

int Brick::count() const {
  int n = 0;
  for (uint64_t w : mask) n += std::popcount(w);
  return n;
}

VoxelGrid::VoxelGrid(const glm::dvec3& origin, double voxel_size) : origin_(origin), voxel_size_(voxel_size) {
  if (!(voxel_size > 0.0) || !std::isfinite(voxel_size)) throw std::invalid_argument("VoxelGrid: voxel size must be > 0");
  if (!std::isfinite(origin.x) || !std::isfinite(origin.y) || !std::isfinite(origin.z))
    throw std::invalid_argument("VoxelGrid: origin must be finite");
}

glm::ivec3 VoxelGrid::world_to_ijk(const glm::dvec3& p) const {
  glm::ivec3 r;
  for (int a = 0; a < 3; ++a) {
    const double f = std::floor((p[a] - origin_[a]) / voxel_size_);
    // Clamp into int32 so far (or NaN) points come back out of range instead of overflowing.
    r[a] = std::isnan(f) ? INT32_MIN : static_cast<int32_t>(std::clamp(f, -2147483648.0, 2147483647.0));
  }
  return r;
}

glm::dvec3 VoxelGrid::ijk_to_world(const glm::ivec3& ijk) const {
  return origin_ + (glm::dvec3(ijk) + 0.5) * voxel_size_;
}

Brick& VoxelGrid::brick_for_write(const glm::ivec3& bc) {
  const uint64_t key = brick_key(bc);
  auto it = index_.find(key);
  if (it != index_.end()) return bricks_[it->second];
  index_.emplace(key, static_cast<uint32_t>(bricks_.size()));
  Brick& b = bricks_.emplace_back();
  b.coord = bc;
  return b;
}

const Brick* VoxelGrid::find_brick(const glm::ivec3& bc) const {
  auto it = index_.find(brick_key(bc));
  return it == index_.end() ? nullptr : &bricks_[it->second];
}

void VoxelGrid::set(const glm::ivec3& ijk, uint8_t class_id, uint16_t instance) {
  if (class_id == 0) {
    erase(ijk);
    return;
  }
  if (class_id >= kNumSemanticClasses)
    throw std::invalid_argument("VoxelGrid::set: class id " + std::to_string(class_id) + " is outside 0..22");
  if (!ijk_in_range(ijk))
    throw std::out_of_range("VoxelGrid::set: voxel (" + std::to_string(ijk.x) + ", " + std::to_string(ijk.y) + ", " +
                            std::to_string(ijk.z) + ") is outside +-2^23");
  Brick& b = brick_for_write(brick_of(ijk));
  const int bit = voxel_bit(ijk);
  uint64_t& w = b.mask[static_cast<size_t>(bit >> 6)];
  const uint64_t m = uint64_t{1} << (bit & 63);
  if (!(w & m)) ++voxel_count_;
  w |= m;
  b.classes[static_cast<size_t>(bit)] = class_id;
  b.instances[static_cast<size_t>(bit)] = instance;
}

Voxel VoxelGrid::get(const glm::ivec3& ijk) const {
  if (!ijk_in_range(ijk)) return {};
  const Brick* b = find_brick(brick_of(ijk));
  if (!b) return {};
  const int bit = voxel_bit(ijk);
  if (!(b->mask[static_cast<size_t>(bit >> 6)] >> (bit & 63) & 1)) return {};
  return {b->classes[static_cast<size_t>(bit)], b->instances[static_cast<size_t>(bit)]};
}

bool VoxelGrid::erase(const glm::ivec3& ijk) {
  if (!ijk_in_range(ijk)) return false;
  auto it = index_.find(brick_key(brick_of(ijk)));
  if (it == index_.end()) return false;
  const uint32_t idx = it->second;
  Brick& b = bricks_[idx];
  const int bit = voxel_bit(ijk);
  uint64_t& w = b.mask[static_cast<size_t>(bit >> 6)];
  const uint64_t m = uint64_t{1} << (bit & 63);
  if (!(w & m)) return false;
  w &= ~m;
  b.classes[static_cast<size_t>(bit)] = 0;
  b.instances[static_cast<size_t>(bit)] = 0;
  --voxel_count_;
  if (b.count() == 0) {  // drop the empty brick: move the last one into its slot
    index_.erase(it);
    const uint32_t last = static_cast<uint32_t>(bricks_.size() - 1);
    if (idx != last) {
      bricks_[idx] = bricks_[last];
      index_[brick_key(bricks_[idx].coord)] = idx;
    }
    bricks_.pop_back();
  }
  return true;
}

void VoxelGrid::clear() {
  bricks_.clear();
  bricks_.shrink_to_fit();
  index_.clear();
  voxel_count_ = 0;
}

std::vector<uint32_t> VoxelGrid::sorted_brick_order() const {
  std::vector<std::pair<uint64_t, uint32_t>> keys;
  keys.reserve(bricks_.size());
  for (uint32_t i = 0; i < bricks_.size(); ++i) keys.emplace_back(brick_key(bricks_[i].coord), i);
  std::sort(keys.begin(), keys.end());
  std::vector<uint32_t> order;
  order.reserve(keys.size());
  for (const auto& k : keys) order.push_back(k.second);
  return order;
}

void VoxelGrid::for_each_voxel(const std::function<void(const glm::ivec3&, const Voxel&)>& fn) const {
  for (uint32_t bi : sorted_brick_order()) {
    const Brick& b = bricks_[bi];
    const glm::ivec3 base = b.coord * kBrickDim;
    for (size_t w = 0; w < 8; ++w) {
      for (uint64_t bits = b.mask[w]; bits; bits &= bits - 1) {
        const int bit = static_cast<int>(w * 64) + std::countr_zero(bits);
        const glm::ivec3 ijk = base + glm::ivec3(bit & 7, (bit >> 3) & 7, bit >> 6);
        fn(ijk, Voxel{b.classes[static_cast<size_t>(bit)], b.instances[static_cast<size_t>(bit)]});
      }
    }
  }
}

IjkBounds VoxelGrid::bounds() const {
  IjkBounds r;
  if (bricks_.empty()) return r;
  r.min = glm::ivec3(INT32_MAX);
  r.max = glm::ivec3(INT32_MIN);
  for (const Brick& b : bricks_) {
    const glm::ivec3 base = b.coord * kBrickDim;
    for (size_t w = 0; w < 8; ++w)
      for (uint64_t bits = b.mask[w]; bits; bits &= bits - 1) {
        const int bit = static_cast<int>(w * 64) + std::countr_zero(bits);
        const glm::ivec3 ijk = base + glm::ivec3(bit & 7, (bit >> 3) & 7, bit >> 6);
        r.min = glm::min(r.min, ijk);
        r.max = glm::max(r.max, ijk);
      }
  }
  return r;
}

std::array<uint64_t, kNumSemanticClasses> VoxelGrid::class_histogram() const {
  std::array<uint64_t, kNumSemanticClasses> h{};
  for (const Brick& b : bricks_)
    for (size_t w = 0; w < 8; ++w)
      for (uint64_t bits = b.mask[w]; bits; bits &= bits - 1)
        ++h[b.classes[w * 64 + static_cast<size_t>(std::countr_zero(bits))]];
  return h;
}

uint64_t VoxelGrid::merge(const VoxelGrid& other, MergePolicy policy) {
  if (other.origin_ != origin_ || other.voxel_size_ != voxel_size_)
    throw std::invalid_argument("VoxelGrid::merge: grids differ in origin or voxel size");
  if (&other == this) return 0;
  uint64_t written = 0;
  other.for_each_voxel([&](const glm::ivec3& ijk, const Voxel& v) {
    if (policy == MergePolicy::ExistingWins && contains(ijk)) return;
    set(ijk, v.class_id, v.instance);
    ++written;
  });
  return written;
}

size_t VoxelGrid::memory_bytes() const {
  // Vector storage plus the hash map's buckets and nodes (key, value, next pointer, cached hash).
  return sizeof(*this) + bricks_.capacity() * sizeof(Brick) + index_.bucket_count() * sizeof(void*) +
         index_.size() * (sizeof(std::pair<const uint64_t, uint32_t>) + 2 * sizeof(void*));
}

void VoxelGrid::insert_brick(const Brick& brick) {
  const uint64_t key = brick_key(brick.coord);
  if (index_.count(key)) throw std::invalid_argument("VoxelGrid::insert_brick: duplicate brick");
  const int n = brick.count();
  if (n == 0) throw std::invalid_argument("VoxelGrid::insert_brick: empty brick");
  index_.emplace(key, static_cast<uint32_t>(bricks_.size()));
  bricks_.push_back(brick);
  voxel_count_ += static_cast<uint64_t>(n);
}

}  // namespace icube::world
