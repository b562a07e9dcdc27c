// Chunk fusion into the world grid, existing voxels winning (chunk_fusion.h).
#include "world/chunk_fusion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

namespace icube::world {

namespace {

constexpr double kRotationTolerance = 1e-12;
constexpr double kShiftTolerance = 1e-6;  // in voxels

// One sub-voxel sample of the re-voxelising path.
struct Sample {
  glm::ivec3 cell{0};
  uint32_t order = 0;  // index of the parent chunk voxel
  uint8_t class_id = 0;
  uint16_t instance = 0;
};

bool cell_less(const glm::ivec3& a, const glm::ivec3& b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

// Writes one cell with existing voxels winning.
void write_cell(VoxelGrid& world, const glm::ivec3& cell, uint8_t class_id, uint16_t instance, FusionStats& st) {
  ++st.cells;
  if (!ijk_in_range(cell)) {
    ++st.out_of_range;
    return;
  }
  if (world.contains(cell)) {
    ++st.kept_existing;
    return;
  }
  world.set(cell, class_id, instance);
  ++st.written;
}

FusionStats fuse_exact(VoxelGrid& world, const ChunkVoxels& chunk, const glm::ivec3& shift) {
  FusionStats st;
  st.exact_copy = true;
  st.chunk_voxels = chunk.voxels.size();
  for (const ChunkVoxel& v : chunk.voxels) {
    const glm::i64vec3 w = glm::i64vec3(v.ijk) + glm::i64vec3(shift);
    const glm::i64vec3 lo(-kMaxIjk - 1), hi(kMaxIjk);
    if (glm::any(glm::lessThan(w, lo)) || glm::any(glm::greaterThan(w, hi))) {
      ++st.cells;
      ++st.out_of_range;
      continue;
    }
    write_cell(world, glm::ivec3(w), v.class_id, v.instance, st);
  }
  return st;
}

FusionStats fuse_resampled(VoxelGrid& world, const ChunkVoxels& chunk) {
  FusionStats st;
  st.chunk_voxels = chunk.voxels.size();
  const double vs = chunk.voxel_size;
  const glm::dmat4& m = chunk.lattice_to_world;
  std::vector<Sample> samples;
  samples.reserve(chunk.voxels.size() * 8);
  for (size_t n = 0; n < chunk.voxels.size(); ++n) {
    const ChunkVoxel& v = chunk.voxels[n];
    for (int s = 0; s < 8; ++s) {
      // Sub-voxel centres of the x2 subdivision: (ijk + 0.25 + 0.5 * bit) * vs.
      const glm::dvec3 local = (glm::dvec3(v.ijk) + glm::dvec3(0.25 + 0.5 * (s & 1), 0.25 + 0.5 * ((s >> 1) & 1),
                                                               0.25 + 0.5 * ((s >> 2) & 1))) *
                               vs;
      const glm::dvec3 p = glm::dvec3(m * glm::dvec4(local, 1.0));
      samples.push_back({world.world_to_ijk(p), static_cast<uint32_t>(n), v.class_id, v.instance});
    }
  }
  std::sort(samples.begin(), samples.end(), [](const Sample& a, const Sample& b) {
    if (a.cell != b.cell) return cell_less(a.cell, b.cell);
    return a.order < b.order;
  });
  for (size_t i = 0; i < samples.size();) {
    size_t j = i;
    std::array<uint16_t, kNumSemanticClasses> votes{};
    while (j < samples.size() && samples[j].cell == samples[i].cell) ++votes[samples[j++].class_id];
    // Majority class, ties to the lowest id (strict > keeps the first maximum).
    uint8_t best = 0;
    for (uint8_t c = 1; c < kNumSemanticClasses; ++c)
      if (votes[c] > votes[best]) best = c;
    uint16_t instance = 0;
    for (size_t k = i; k < j; ++k)
      if (samples[k].class_id == best) {
        instance = samples[k].instance;  // the first sample of that class in chunk voxel order
        break;
      }
    write_cell(world, samples[i].cell, best, instance, st);
    i = j;
  }
  return st;
}

}  // namespace

bool lattice_aligned(const ChunkVoxels& chunk, const VoxelGrid& world, glm::ivec3* shift) {
  if (std::abs(chunk.voxel_size - world.voxel_size()) > kRotationTolerance * world.voxel_size()) return false;
  const glm::dmat4& m = chunk.lattice_to_world;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r)
      if (std::abs(m[c][r] - (c == r ? 1.0 : 0.0)) > kRotationTolerance) return false;
  const glm::dvec3 offset = (glm::dvec3(m[3]) - world.origin()) / world.voxel_size();
  const glm::dvec3 whole = glm::round(offset);
  if (glm::any(glm::greaterThan(glm::abs(offset - whole), glm::dvec3(kShiftTolerance)))) return false;
  if (glm::any(glm::greaterThan(glm::abs(whole), glm::dvec3(static_cast<double>(kMaxIjk))))) return false;
  if (shift) *shift = glm::ivec3(whole);
  return true;
}

FusionStats fuse_chunk(VoxelGrid& world, const ChunkVoxels& chunk) {
  glm::ivec3 shift(0);
  if (lattice_aligned(chunk, world, &shift)) return fuse_exact(world, chunk, shift);
  return fuse_resampled(world, chunk);
}

}  // namespace icube::world
