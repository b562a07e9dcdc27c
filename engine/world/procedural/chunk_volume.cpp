// Dense chunk volume with ranked writes, and the shape voxelisers (see chunk_volume.h).
#include "world/procedural/chunk_volume.h"

#include "world/procedural/hash_noise.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace icube::world::procedural {

namespace {

using SC = SemanticClass;
constexpr uint8_t id(SC c) { return static_cast<uint8_t>(c); }

constexpr std::array<uint8_t, kNumSemanticClasses> make_ranks() {
  std::array<uint8_t, kNumSemanticClasses> r{};
  uint8_t next = 1;
  // lowest to highest: ground bands, road, markings, canopy, buildings, trunks, furniture
  for (SC c : {SC::OtherGround, SC::Walkable, SC::Sidewalk, SC::Curb, SC::Road, SC::LaneMarker, SC::Vegetation,
               SC::Building, SC::TreeTrunk, SC::Sign, SC::TrafficLight, SC::Pole})
    r[id(c)] = next++;
  for (size_t c = 1; c < r.size(); ++c)
    if (r[c] == 0) r[c] = next;  // vehicles and others (not written here) outrank everything; empty stays 0
  return r;
}
constexpr auto kRanks = make_ranks();

constexpr uint64_t kWobbleSalt = 0xC0FFEE;  // noise salt of canopy lumps (any constant)
constexpr double kMinPoleRadius = 0.1415;  // half a 0.2 m cell's diagonal: some cell centre is always this close

}  // namespace

uint8_t class_rank(uint8_t class_id) { return class_id < kNumSemanticClasses ? kRanks[class_id] : 0; }

void ChunkVolume::init(const glm::dvec3& world_origin, double voxel, const glm::ivec3& ijk_lo,
                       const glm::ivec3& ijk_hi) {
  origin = world_origin, vs = voxel, lo = ijk_lo;
  dim = glm::max(ijk_hi - ijk_lo + 1, glm::ivec3(0));
  cls.assign(static_cast<size_t>(dim.x) * static_cast<size_t>(dim.y) * static_cast<size_t>(dim.z), 0);
  drivable.assign(static_cast<size_t>(dim.x) * static_cast<size_t>(dim.y), 0);
}

void ChunkVolume::put(int i, int j, int k, uint8_t class_id) {
  if (!in_xy(i, j) || k < lo.z || k >= lo.z + dim.z) return;
  const size_t col = column(i, j);
  if (drivable[col] && class_id != id(SC::Road) && class_id != id(SC::LaneMarker)) return;
  uint8_t& c = cls[col + static_cast<size_t>(dim.x) * static_cast<size_t>(dim.y) * static_cast<size_t>(k - lo.z)];
  if (class_rank(class_id) > class_rank(c)) c = class_id;
}

void ChunkVolume::put_column(int i, int j, int k0, int k1, uint8_t class_id) {
  if (!in_xy(i, j)) return;
  for (int k = std::max(k0, lo.z); k <= std::min(k1, lo.z + dim.z - 1); ++k) put(i, j, k, class_id);
}

void voxelise_cylinder(ChunkVolume& v, const glm::dvec2& axis, double radius, double z0, double z1, uint8_t cls) {
  const double r = std::max(radius, kMinPoleRadius);
  const int k0 = v.k_of(z0), k1 = v.k_of(z1);
  for (int j = v.j_of(axis.y - r); j <= v.j_of(axis.y + r); ++j)
    for (int i = v.i_of(axis.x - r); i <= v.i_of(axis.x + r); ++i) {
      const double dx = v.cx(i) - axis.x, dy = v.cy(j) - axis.y;
      if (dx * dx + dy * dy <= r * r) v.put_column(i, j, k0, k1, cls);
    }
}

void voxelise_box(ChunkVolume& v, const glm::dvec3& c, const glm::dvec2& u, const glm::dvec3& half, uint8_t cls) {
  const glm::dvec2 w(-u.y, u.x);
  const double ext = std::sqrt(half.x * half.x + half.y * half.y);
  for (int k = v.k_of(c.z - half.z); k <= v.k_of(c.z + half.z); ++k) {
    if (std::abs(v.cz(k) - c.z) > half.z) continue;
    for (int j = v.j_of(c.y - ext); j <= v.j_of(c.y + ext); ++j)
      for (int i = v.i_of(c.x - ext); i <= v.i_of(c.x + ext); ++i) {
        const glm::dvec2 d(v.cx(i) - c.x, v.cy(j) - c.y);
        if (std::abs(glm::dot(d, u)) <= half.x && std::abs(glm::dot(d, w)) <= half.y) v.put(i, j, k, cls);
      }
  }
}

void voxelise_plate(ChunkVolume& v, const glm::dvec3& c, const glm::dvec2& n, double radius, uint8_t cls) {
  const double half_thick = 0.5 * v.vs;  // one voxel
  for (int k = v.k_of(c.z - radius); k <= v.k_of(c.z + radius); ++k)
    for (int j = v.j_of(c.y - radius); j <= v.j_of(c.y + radius); ++j)
      for (int i = v.i_of(c.x - radius); i <= v.i_of(c.x + radius); ++i) {
        const glm::dvec3 d(v.cx(i) - c.x, v.cy(j) - c.y, v.cz(k) - c.z);
        const double along = d.x * n.x + d.y * n.y;
        if (std::abs(along) > half_thick) continue;
        const double in_plane2 = d.x * d.x + d.y * d.y - along * along + d.z * d.z;
        if (in_plane2 <= radius * radius) v.put(i, j, k, cls);
      }
}

void voxelise_ellipsoid(ChunkVolume& v, const glm::dvec3& c, double rxy, double rz, double thickness, double wobble,
                        uint64_t noise_seed, uint8_t cls) {
  constexpr double kWobbleWavelength = 1.2;  // m: lumps of about a branch cluster
  const double grow = 1.0 + wobble;          // outermost normalised radius any noise value reaches
  const double rel_thick = thickness > 0.0 ? thickness / std::min(rxy, rz) : 2.0;
  const double inner = std::max(0.0, 1.0 - wobble - rel_thick);  // innermost normalised radius of the shell
  const double ez = rz * grow;
  for (int k = v.k_of(c.z - ez); k <= v.k_of(c.z + ez); ++k) {
    const double z = v.cz(k), dz = (z - c.z) / rz;
    if (dz * dz > grow * grow) continue;
    const double sy = rxy * std::sqrt(grow * grow - dz * dz);
    for (int j = v.j_of(c.y - sy); j <= v.j_of(c.y + sy); ++j) {
      const double y = v.cy(j), dy = (y - c.y) / rxy;
      const double rest = grow * grow - dz * dz - dy * dy;
      if (rest < 0.0) continue;
      // the row's cells lie in [-outer, -in] and [in, outer] about the centre (normalised x)
      const double outer = std::sqrt(rest);
      const double in2 = inner * inner - dz * dz - dy * dy;
      const double in = in2 > 0.0 ? std::sqrt(in2) : 0.0;
      for (int i = v.i_of(c.x - outer * rxy); i <= v.i_of(c.x + outer * rxy); ++i) {
        const double x = v.cx(i), dx = (x - c.x) / rxy;
        if (std::abs(dx) < in) {  // jump over the hollow middle
          i = std::max(i, v.i_of(c.x + in * rxy) - 1);
          continue;
        }
        const double e = std::sqrt(dx * dx + dy * dy + dz * dz);
        if (e > grow || e < inner) continue;
        const double f = wobble > 0.0
                             ? 1.0 + wobble * (2.0 * value_noise3(noise_seed, kWobbleSalt, x, y, z, kWobbleWavelength) - 1.0)
                             : 1.0;
        if (e <= f && e >= f - rel_thick) v.put(i, j, k, cls);
      }
    }
  }
}

}  // namespace icube::world::procedural
