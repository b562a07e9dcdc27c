// World voxels re-voxelised into a chunk's frame; see chunk_voxels.h.
#include "world/chunk_voxels.h"

#include <cmath>
#include <map>

namespace icube::world {

ChunkVoxelList chunk_voxels(const VoxelGrid& world, const ChunkPose& chunk) {
  const glm::dmat4 world_to_chunk = glm::inverse(chunk.chunk_to_world);
  constexpr int32_t kHalf[3] = {128, 128, 64};
  std::map<std::array<int32_t, 3>, std::array<uint32_t, kNumSemanticClasses>> votes;
  world.for_each_voxel([&](const glm::ivec3& ijk, const Voxel& v) {
    const glm::dvec3 p = glm::dvec3(world_to_chunk * glm::dvec4(world.ijk_to_world(ijk), 1.0));
    std::array<int32_t, 3> c{};
    for (int d = 0; d < 3; ++d) {
      const double q = std::round((p[d] - kFineVoxel / 2) / kFineVoxel);
      if (!(q >= -kHalf[d] && q < kHalf[d])) return;
      c[static_cast<size_t>(d)] = static_cast<int32_t>(q);
    }
    ++votes[c][v.class_id];
  });
  ChunkVoxelList out;
  out.ijk.reserve(votes.size());
  for (const auto& [c, count] : votes) {
    size_t best = 1;
    for (size_t k = 2; k < count.size(); ++k)
      if (count[k] > count[best]) best = k;
    out.ijk.push_back(c);
    out.class_id.push_back(static_cast<uint8_t>(best));
  }
  return out;
}

}  // namespace icube::world
