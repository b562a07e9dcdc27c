// The sparse semantic voxel world: per voxel a class id (1..22; 0 = empty is
// never stored) and an instance id (uint16).
//
// Storage is 8x8x8 bricks: a 512-bit occupancy mask and dense per-brick class
// and instance arrays, kept in a vector and found through a hash map keyed on
// the packed brick coordinate (brick_key). A brick that loses its last voxel
// is removed, so memory follows the number of occupied bricks.
//
// Coordinates: the world origin is a glm::dvec3 (metres) and voxels have int32
// ijk; the centre of voxel ijk is origin + (ijk + 0.5) * voxel_size, i.e.
// fVDB's ijk*vs + vs/2 with the grid origin at `origin` (conventions §2). With
// the origin in double and ijk relative to it, a world 100 km across keeps
// millimetre precision. ijk must lie in [-kMaxIjk - 1, kMaxIjk] on every axis
// (+-8.4 M voxels, +-1678 km at 0.2 m) so that a brick coordinate packs into
// 21 bits per axis; outside that, set() throws std::out_of_range and get()
// returns empty.
//
// Within a brick, voxel (lx, ly, lz) is bit lx + 8 ly + 64 lz of the mask
// (x fastest). Tests: tests/world/test_voxel_grid.cpp.
#pragma once

#include "world/chunk_pose.h"
#include "world/semantics.h"

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

namespace icube::world {

inline constexpr int kBrickDim = 8;
inline constexpr int kBrickVoxels = 512;
inline constexpr int32_t kMaxIjk = (1 << 23) - 1;       // largest valid voxel coordinate
inline constexpr int32_t kBrickCoordBias = 1 << 20;     // brick coordinate + bias fits 21 bits
inline constexpr uint64_t kBrickAxisMask = (1u << 21) - 1;

struct Voxel {
  uint8_t class_id = 0;  // 0 = empty
  uint16_t instance = 0;
};

struct IjkBounds {
  glm::ivec3 min{0};
  glm::ivec3 max{-1};  // inclusive; min > max when empty
  bool empty() const { return min.x > max.x; }
};

enum class MergePolicy { ExistingWins, Overwrite };

struct Brick {
  glm::ivec3 coord{0};  // brick coordinate = floor(ijk / 8)
  std::array<uint64_t, 8> mask{};
  std::array<uint8_t, kBrickVoxels> classes{};
  std::array<uint16_t, kBrickVoxels> instances{};
  int count() const;
};

inline bool ijk_in_range(const glm::ivec3& ijk) {
  return ijk.x >= -kMaxIjk - 1 && ijk.x <= kMaxIjk && ijk.y >= -kMaxIjk - 1 && ijk.y <= kMaxIjk &&
         ijk.z >= -kMaxIjk - 1 && ijk.z <= kMaxIjk;
}
inline glm::ivec3 brick_of(const glm::ivec3& ijk) { return {ijk.x >> 3, ijk.y >> 3, ijk.z >> 3}; }
inline int voxel_bit(const glm::ivec3& ijk) { return (ijk.x & 7) | ((ijk.y & 7) << 3) | ((ijk.z & 7) << 6); }
// Packed brick coordinate: (bx + bias) | (by + bias) << 21 | (bz + bias) << 42; sorts z-major.
inline uint64_t brick_key(const glm::ivec3& b) {
  return static_cast<uint64_t>(b.x + kBrickCoordBias) | (static_cast<uint64_t>(b.y + kBrickCoordBias) << 21) |
         (static_cast<uint64_t>(b.z + kBrickCoordBias) << 42);
}
inline glm::ivec3 brick_from_key(uint64_t key) {
  return {static_cast<int32_t>(key & kBrickAxisMask) - kBrickCoordBias,
          static_cast<int32_t>((key >> 21) & kBrickAxisMask) - kBrickCoordBias,
          static_cast<int32_t>((key >> 42) & kBrickAxisMask) - kBrickCoordBias};
}

class VoxelGrid {
 public:
  explicit VoxelGrid(const glm::dvec3& origin = glm::dvec3(0.0), double voxel_size = kFineVoxel);

  const glm::dvec3& origin() const { return origin_; }
  double voxel_size() const { return voxel_size_; }

  // floor((p - origin) / vs) per axis, clamped to int32 (NaN -> INT32_MIN); far points come back
  // out of range: check ijk_in_range.
  glm::ivec3 world_to_ijk(const glm::dvec3& p) const;
  glm::dvec3 ijk_to_world(const glm::ivec3& ijk) const;  // voxel centre

  // class_id 0 erases; class_id > 22 throws std::invalid_argument; ijk out of range throws std::out_of_range.
  void set(const glm::ivec3& ijk, uint8_t class_id, uint16_t instance = 0);
  Voxel get(const glm::ivec3& ijk) const;
  bool contains(const glm::ivec3& ijk) const { return get(ijk).class_id != 0; }
  bool erase(const glm::ivec3& ijk);  // true if a voxel was removed
  void clear();

  // Every occupied voxel: bricks in ascending brick_key order, voxels in mask order.
  void for_each_voxel(const std::function<void(const glm::ivec3&, const Voxel&)>& fn) const;
  // Brick indices sorted by brick_key (the deterministic order of for_each_voxel and the file).
  std::vector<uint32_t> sorted_brick_order() const;
  const std::vector<Brick>& bricks() const { return bricks_; }
  const Brick* find_brick(const glm::ivec3& brick_coord) const;

  uint64_t voxel_count() const { return voxel_count_; }
  size_t brick_count() const { return bricks_.size(); }
  IjkBounds bounds() const;
  std::array<uint64_t, kNumSemanticClasses> class_histogram() const;
  // Merges `other` (same origin and voxel size, else std::invalid_argument); returns voxels written.
  uint64_t merge(const VoxelGrid& other, MergePolicy policy);
  size_t memory_bytes() const;

  // Adds a whole brick (for readers); throws std::invalid_argument if it exists or is empty.
  void insert_brick(const Brick& brick);

 private:
  Brick& brick_for_write(const glm::ivec3& bc);
  glm::dvec3 origin_;
  double voxel_size_;
  std::vector<Brick> bricks_;
  std::unordered_map<uint64_t, uint32_t> index_;  // brick_key -> index into bricks_
  uint64_t voxel_count_ = 0;
};

}  // namespace icube::world
