// Outpainting's store of generated latents; see latent_store.h.
#include "diffusion/latent_store.h"

#include <cmath>
#include <stdexcept>

namespace icube::diffusion {

namespace {

constexpr int kDim = world::kLatentDim, kHalf = kDim / 2;
constexpr size_t kCells = static_cast<size_t>(kDim) * kDim * kDim;

size_t cell_index(int i, int j, int k) {
  return (static_cast<size_t>(i + kHalf) * kDim + static_cast<size_t>(j + kHalf)) * kDim + static_cast<size_t>(k + kHalf);
}

glm::dvec3 cell_centre(int i, int j, int k) {
  return (glm::dvec3(i, j, k) + 0.5) * world::kLatentVoxel;
}

// The nearest cell of a chunk-frame point, or false outside [-32, 32)^3.
bool nearest_cell(const glm::dvec3& q, glm::ivec3& ijk) {
  for (int d = 0; d < 3; ++d) {
    const double c = std::round(q[d] / world::kLatentVoxel[d] - 0.5);
    if (!(c >= -kHalf && c < kHalf)) return false;
    ijk[d] = static_cast<int>(c);
  }
  return true;
}

}  // namespace

LatentStore::LatentStore(world::PlanMode mode, int channels) : mode_(mode), channels_(channels) {
  if (channels < 1) throw std::invalid_argument("latent store: " + std::to_string(channels) + " channels");
}

uint64_t LatentStore::world_key(const glm::dvec3& p) const {
  uint64_t key = 0;
  for (int d = 0; d < 3; ++d) {
    const double c = std::round((p[d] - reference_[d]) / world::kLatentVoxel[d] - 0.5);
    key |= (static_cast<uint64_t>(static_cast<int64_t>(c) + (int64_t{1} << 20)) & 0x1fffffu) << (21 * d);
  }
  return key;
}

KnownLatents LatentStore::known_for(const world::ChunkPose& pose) const {
  KnownLatents k;
  if (chunks_ == 0) return k;
  const size_t C = static_cast<size_t>(channels_);
  k.mask.assign(kCells, 0);
  k.values.assign(C * kCells, 0.0f);
  if (mode_ == world::PlanMode::Trajectory) {
    const glm::dmat4 prev_to_new = glm::inverse(pose.chunk_to_world) * last_pose_.chunk_to_world;
    for (int i = -kHalf; i < kHalf; ++i)
      for (int j = -kHalf; j < kHalf; ++j)
        for (int kk = -kHalf; kk < kHalf; ++kk) {
          glm::ivec3 t;
          if (!nearest_cell(glm::dvec3(prev_to_new * glm::dvec4(cell_centre(i, j, kk), 1.0)), t)) continue;
          const size_t src = cell_index(i, j, kk), dst = cell_index(t.x, t.y, t.z);
          k.mask[dst] = 1;
          for (size_t c = 0; c < C; ++c) k.values[c * kCells + dst] = last_latent_[c * kCells + src];
        }
  } else {
    for (int i = -kHalf; i < kHalf; ++i)
      for (int j = -kHalf; j < kHalf; ++j)
        for (int kk = -kHalf; kk < kHalf; ++kk) {
          const auto it = rows_.find(world_key(glm::dvec3(pose.chunk_to_world * glm::dvec4(cell_centre(i, j, kk), 1.0))));
          if (it == rows_.end()) continue;
          const size_t dst = cell_index(i, j, kk);
          k.mask[dst] = 1;
          for (size_t c = 0; c < C; ++c) k.values[c * kCells + dst] = values_[size_t{it->second} * C + c];
        }
  }
  return k;
}

void LatentStore::add(const world::ChunkPose& pose, const std::vector<float>& latent) {
  const size_t C = static_cast<size_t>(channels_);
  if (latent.size() != C * kCells)
    throw std::invalid_argument("latent store: a latent of " + std::to_string(latent.size()) + " values, not " +
                                std::to_string(C) + " x 64^3");
  if (mode_ == world::PlanMode::Trajectory) {
    last_pose_ = pose;
    last_latent_ = latent;
  } else {
    if (chunks_ == 0) reference_ = glm::dvec3(pose.chunk_to_world[3]);
    for (int i = -kHalf; i < kHalf; ++i)
      for (int j = -kHalf; j < kHalf; ++j)
        for (int kk = -kHalf; kk < kHalf; ++kk) {
          const uint64_t key = world_key(glm::dvec3(pose.chunk_to_world * glm::dvec4(cell_centre(i, j, kk), 1.0)));
          if (!rows_.emplace(key, static_cast<uint32_t>(values_.size() / C)).second) continue;  // first writer wins
          const size_t src = cell_index(i, j, kk);
          for (size_t c = 0; c < C; ++c) values_.push_back(latent[c * kCells + src]);
        }
  }
  ++chunks_;
}

}  // namespace icube::diffusion
