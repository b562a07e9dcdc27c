// The procedural prior's per-chunk output buffer: a dense class volume over
// the world-lattice cells of the chunk's world-axis bounding box. Writes keep
// the class of higher rank (structures over ground, poles over canopies), so
// the result does not depend on the order in which rules write; columns
// flagged drivable accept only ROAD and LANE_MARKER (the hard rule). Also the
// shape voxelisers every structure uses (cylinder, oriented box, vertical
// disc, ellipsoid shell), all evaluated at voxel centres in world metres.
#pragma once

#include "world/generator.h"
#include "world/semantics.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace icube::world::procedural {

// Priority when two rules claim one cell (higher wins).
uint8_t class_rank(uint8_t class_id);

struct ChunkVolume {
  glm::dvec3 origin{0.0};  // world grid origin
  double vs = kFineVoxel;
  glm::ivec3 lo{0}, dim{0};  // world ijk of cell (0, 0, 0) and the extent
  std::vector<uint8_t> cls;  // dim.x * dim.y * dim.z, x fastest
  std::vector<uint8_t> drivable;  // dim.x * dim.y, per column

  void init(const glm::dvec3& world_origin, double voxel, const glm::ivec3& ijk_lo, const glm::ivec3& ijk_hi);
  size_t column(int i, int j) const {  // world i, j (must be inside)
    return static_cast<size_t>(i - lo.x) + static_cast<size_t>(dim.x) * static_cast<size_t>(j - lo.y);
  }
  bool in_xy(int i, int j) const { return i >= lo.x && j >= lo.y && i < lo.x + dim.x && j < lo.y + dim.y; }
  void put(int i, int j, int k, uint8_t class_id);
  void put_column(int i, int j, int k0, int k1, uint8_t class_id);  // k0..k1 inclusive

  int k_of(double z) const { return static_cast<int>(std::floor((z - origin.z) / vs)); }
  int i_of(double x) const { return static_cast<int>(std::floor((x - origin.x) / vs)); }
  int j_of(double y) const { return static_cast<int>(std::floor((y - origin.y) / vs)); }
  double cx(int i) const { return origin.x + (i + 0.5) * vs; }
  double cy(int j) const { return origin.y + (j + 0.5) * vs; }
  double cz(int k) const { return origin.z + (k + 0.5) * vs; }
};

// Vertical cylinder about (x, y) from z0 to z1; radius at least half a cell
// diagonal so a thin pole always covers one column.
void voxelise_cylinder(ChunkVolume& v, const glm::dvec2& axis, double radius, double z0, double z1, uint8_t cls);
// Box with yaw: centre, unit x axis in the plane (u), half extents along u, v = perp(u), z.
void voxelise_box(ChunkVolume& v, const glm::dvec3& centre, const glm::dvec2& u, const glm::dvec3& half,
                  uint8_t cls);
// Vertical disc of one voxel thickness: centre, horizontal unit normal, radius.
void voxelise_plate(ChunkVolume& v, const glm::dvec3& centre, const glm::dvec2& normal, double radius, uint8_t cls);
// Ellipsoid (radii r_xy, r_z) shell of `thickness` metres with its radius
// perturbed by 3D value noise of relative amplitude `wobble`; thickness <= 0: solid.
void voxelise_ellipsoid(ChunkVolume& v, const glm::dvec3& centre, double r_xy, double r_z, double thickness,
                        double wobble, uint64_t noise_seed, uint8_t cls);

}  // namespace icube::world::procedural
