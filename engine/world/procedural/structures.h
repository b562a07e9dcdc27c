// The procedural prior's buildings and trees as voxel shapes: a building is a
// rotated rectangular footprint with a seeded height and roof (flat, flat
// with a parapet, or pitched), voxelised as a shell (walls two voxels thick
// plus the roof) so memory follows surfaces as in LiDAR-derived worlds; a
// tree is a TREE_TRUNK cylinder under a lumpy VEGETATION crown shell.
#pragma once

#include "world/procedural/chunk_volume.h"
#include "world/procedural/hash_noise.h"
#include "world/procedural/procedural_prior.h"

#include <glm/glm.hpp>

#include <cmath>
#include <cstdint>

namespace icube::world::procedural {

struct Footprint {
  glm::dvec2 c{0.0}, u{1.0, 0.0}, w{0.0, 1.0};
  double a = 0.0, b = 0.0;  // half extents along u (road direction) and w
  glm::dvec2 local(const glm::dvec2& p) const { return {glm::dot(p - c, u), glm::dot(p - c, w)}; }
  bool contains(const glm::dvec2& p, double pad = 0.0) const {
    const glm::dvec2 l = local(p);
    return std::abs(l.x) <= a + pad && std::abs(l.y) <= b + pad;
  }
};

struct BuildingStyle {
  double height = 6.0;  // eave (flat: roof) height plus the ridge rise of a pitched roof
  bool gable = false, parapet = false;
};

// Draws the height and roof of a building from `hs`.
BuildingStyle building_style(HashStream& hs, const ProceduralOptions& options, const Footprint& fp);
// The shell, standing on base_z (walls start one voxel below it).
void voxelise_building(ChunkVolume& v, const Footprint& fp, const BuildingStyle& style, double base_z);
// A tree whose shape is drawn from `key`, its trunk standing on base_z at p.
void voxelise_tree(ChunkVolume& v, const glm::dvec2& p, double base_z, uint64_t key);

}  // namespace icube::world::procedural
