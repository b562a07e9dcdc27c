// The procedural prior's per-chunk BEV raster: square cells of the world
// lattice's voxel size, aligned with the world grid's columns (cell (x, y) is
// voxel column (i0 + x, j0 + y)), and the exact Euclidean distance transform
// (Felzenszwalb & Huttenlocher) of a binary mask on it. Distances are exact
// integers (squared, in cells), so two rasters over different extents agree
// wherever the nearest set cell lies inside both.
#pragma once

#include <glm/glm.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

namespace icube::world::procedural {

struct BevRaster {
  glm::ivec2 ij0{0};   // world column of cell (0, 0)
  int nx = 0, ny = 0;
  glm::dvec2 origin{0.0};  // world grid origin x, y
  double cell = 0.2;

  size_t size() const { return static_cast<size_t>(nx) * static_cast<size_t>(ny); }
  size_t index(int x, int y) const { return static_cast<size_t>(x) + static_cast<size_t>(nx) * static_cast<size_t>(y); }
  bool in(int x, int y) const { return x >= 0 && y >= 0 && x < nx && y < ny; }
  // Centre of cell (x, y) in world x, y.
  glm::dvec2 centre(int x, int y) const {
    return origin + (glm::dvec2(ij0.x + x, ij0.y + y) + 0.5) * cell;
  }
  // Cell containing world (x, y) (may be outside the raster).
  glm::ivec2 cell_of(const glm::dvec2& p) const {
    const glm::dvec2 q = (p - origin) / cell;
    return glm::ivec2(static_cast<int>(std::floor(q.x)) - ij0.x, static_cast<int>(std::floor(q.y)) - ij0.y);
  }
};

// Squared distance (in cells) from every cell to the nearest cell with mask != 0;
// kFarSquared where the mask is empty.
inline constexpr float kFarSquared = 1e18f;
std::vector<float> squared_distance_transform(const std::vector<uint8_t>& mask, int nx, int ny);

}  // namespace icube::world::procedural
