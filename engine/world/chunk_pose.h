// Where one Stage-1 chunk sits in the world (conventions §1, §2, §7).
//
// The chunk frame has the key camera's FLU axes (x forward, y left, z up) and
// its origin at the centre of the crop box: 6.4 m above the key camera along
// its up axis (crop x, y in [-25.6, 25.6], z in [-6.4, 19.2] about the
// camera). Fine voxels are 0.2 m (256 x 256 x 128 per chunk, centres at
// integer ijk, origin vs/2); the latent grid is dense 64^3 at 0.8 x 0.8 x 0.4 m
// with ijk in [-32, 31] and origin (0.4, 0.4, 0.2). In blocks mode the axes
// are the world's (translation-only lattice).
#pragma once

#include <glm/glm.hpp>

#include <cstdint>

namespace icube::world {

inline constexpr double kFineVoxel = 0.2;
inline constexpr glm::dvec3 kLatentVoxel{0.8, 0.8, 0.4};
inline constexpr int kLatentDim = 64;
inline constexpr glm::dvec3 kChunkHalfExtent{25.6, 25.6, 12.8};
inline constexpr double kChunkUpOffset = 6.4;   // chunk centre above the key camera
inline constexpr double kChunkStride = 38.4;    // metres between key poses / blocks

struct ChunkPose {
  int32_t index = 0;
  glm::dmat4 chunk_to_world{1.0};  // rigid; columns 0..2 = chunk x, y, z axes in world
  glm::dvec3 key_camera_world{0.0};  // trajectory mode: the key camera position
};

}  // namespace icube::world
