// World voxels re-voxelised into a chunk's frame; see chunk_voxels.h.
//
// Only the bricks whose box meets the chunk box (its world-space bounding box)
// are visited, so the cost follows the chunk, not the world. Votes are packed
// (chunk cell, class) keys, sorted; a run of one cell is counted per class:
// 8 bytes a voxel instead of a map node with 23 counters.
#include "world/chunk_voxels.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace icube::world {

namespace {

constexpr int32_t kHalf[3] = {128, 128, 64};

// Cell ijk in [-128, 128) x [-128, 128) x [-64, 64) packed with the class into one sortable key
// (ascending key = ascending (i, j, k) lexicographically, then class).
uint64_t pack(const std::array<int32_t, 3>& c, uint8_t cls) {
  return (static_cast<uint64_t>(c[0] + kHalf[0]) << 24) | (static_cast<uint64_t>(c[1] + kHalf[1]) << 16) |
         (static_cast<uint64_t>(c[2] + kHalf[2]) << 8) | cls;
}

}  // namespace

ChunkVoxelList chunk_voxels(const VoxelGrid& world, const ChunkPose& chunk) {
  const glm::dmat4 world_to_chunk = glm::inverse(chunk.chunk_to_world);
  // The chunk box in world coordinates (with a voxel of margin for the rounding at its faces).
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
  for (int corner = 0; corner < 8; ++corner) {
    const glm::dvec3 q((corner & 1 ? 1 : -1) * (kHalf[0] + 1) * kFineVoxel, (corner & 2 ? 1 : -1) * (kHalf[1] + 1) * kFineVoxel,
                       (corner & 4 ? 1 : -1) * (kHalf[2] + 1) * kFineVoxel);
    const glm::dvec3 p(chunk.chunk_to_world * glm::dvec4(q, 1.0));
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const double brick_m = world.voxel_size() * kBrickDim;
  std::vector<uint64_t> votes;
  for (const Brick& b : world.bricks()) {
    const glm::dvec3 b_lo = world.origin() + glm::dvec3(b.coord) * brick_m, b_hi = b_lo + brick_m;
    if (b_hi.x < lo.x || b_hi.y < lo.y || b_hi.z < lo.z || b_lo.x > hi.x || b_lo.y > hi.y || b_lo.z > hi.z) continue;
    for (int w = 0; w < 8; ++w)
      for (uint64_t m = b.mask[static_cast<size_t>(w)]; m != 0; m &= m - 1) {
        const int bit = w * 64 + __builtin_ctzll(m);
        const glm::ivec3 ijk = b.coord * kBrickDim + glm::ivec3(bit & 7, (bit >> 3) & 7, bit >> 6);
        const glm::dvec3 p = glm::dvec3(world_to_chunk * glm::dvec4(world.ijk_to_world(ijk), 1.0));
        std::array<int32_t, 3> c{};
        bool inside = true;
        for (int d = 0; d < 3 && inside; ++d) {
          const double q = std::round((p[d] - kFineVoxel / 2) / kFineVoxel);
          inside = q >= -kHalf[d] && q < kHalf[d];
          c[static_cast<size_t>(d)] = inside ? static_cast<int32_t>(q) : 0;
        }
        if (inside) votes.push_back(pack(c, b.classes[static_cast<size_t>(bit)]));
      }
  }
  std::sort(votes.begin(), votes.end());
  ChunkVoxelList out;
  for (size_t i = 0; i < votes.size();) {
    const uint64_t cell = votes[i] >> 8;
    // Runs of one class within the cell's run; the largest wins, ties to the lowest id (first run).
    uint8_t best = 0;
    size_t best_count = 0;
    while (i < votes.size() && votes[i] >> 8 == cell) {
      size_t j = i;
      while (j < votes.size() && votes[j] == votes[i]) ++j;
      if (j - i > best_count) best = static_cast<uint8_t>(votes[i] & 0xff), best_count = j - i;
      i = j;
    }
    out.ijk.push_back({static_cast<int32_t>((cell >> 16) & 0xffff) - kHalf[0], static_cast<int32_t>((cell >> 8) & 0xff) - kHalf[1],
                       static_cast<int32_t>(cell & 0xff) - kHalf[2]});
    out.class_id.push_back(best);
  }
  return out;
}

}  // namespace icube::world
