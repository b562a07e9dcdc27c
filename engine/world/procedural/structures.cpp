// Building shells and trees of the procedural prior (see structures.h).
#include "world/procedural/structures.h"

#include "world/semantics.h"

#include <algorithm>

namespace icube::world::procedural {

namespace {

constexpr uint8_t kBuilding = static_cast<uint8_t>(SemanticClass::Building);
constexpr double kMaxBuildingHeight = 19.0;  // chunk top is ~20.7 m above the road (19.2 m above the camera)
constexpr double kWall = 0.4;                // walls two voxels thick
constexpr double kGableSlope = 0.5;          // ~27 degree pitch
constexpr double kGableMaxHeight = 9.0;      // houses up to two storeys get pitched roofs
constexpr double kMinEave = 2.5;             // a pitched house keeps at least one storey of wall
constexpr double kGableShare = 0.5, kParapetShare = 0.6;  // of low houses / of flat roofs
constexpr double kParapet = 1.0;
constexpr double kCanopyShell = 0.4;         // crown shell thickness (two voxels)
constexpr double kCanopyWobble = 0.15;       // crown radius varies +-15 %
constexpr uint64_t kSaltCrown = 0xC20;       // noise salt of the crown lumps (any constant)

struct TreeShape {
  double trunk = 2.5, r = 2.5, rz = 2.0;
};

TreeShape tree_shape(uint64_t key) {
  HashStream h(key);
  TreeShape t;
  t.trunk = h.range(2.0, 3.0);      // clear trunk below the crown
  t.r = h.range(1.5, 3.5);          // crown radius: young street trees to mature shade trees
  t.rz = t.r * h.range(0.75, 1.0);  // crowns slightly flattened
  return t;
}

}  // namespace

BuildingStyle building_style(HashStream& hs, const ProceduralOptions& o, const Footprint& fp) {
  BuildingStyle s;
  const double u = hs.next();
  // Skewed low (u^2): most lots hold one- or two-storey houses, a few tall blocks.
  s.height = std::min(kMaxBuildingHeight, o.building_height_min + (o.building_height_max - o.building_height_min) * u * u);
  s.gable = s.height <= kGableMaxHeight && hs.next() < kGableShare && s.height - fp.b * kGableSlope >= kMinEave;
  s.parapet = !s.gable && hs.next() < kParapetShare;
  return s;
}

void voxelise_building(ChunkVolume& v, const Footprint& fp, const BuildingStyle& s, double base) {
  const double eave = s.gable ? s.height - fp.b * kGableSlope : s.height;
  const int k0 = v.k_of(base);  // one voxel buried: no gap on gentle slopes
  const double ext = std::sqrt(fp.a * fp.a + fp.b * fp.b);
  for (int j = std::max(v.j_of(fp.c.y - ext), v.lo.y); j <= std::min(v.j_of(fp.c.y + ext), v.lo.y + v.dim.y - 1); ++j)
    for (int i = std::max(v.i_of(fp.c.x - ext), v.lo.x); i <= std::min(v.i_of(fp.c.x + ext), v.lo.x + v.dim.x - 1);
         ++i) {
      const glm::dvec2 l = fp.local({v.cx(i), v.cy(j)});
      if (std::abs(l.x) > fp.a || std::abs(l.y) > fp.b) continue;
      const bool side = std::abs(l.y) > fp.b - kWall, end = std::abs(l.x) > fp.a - kWall;
      const double roof = s.gable ? eave + (fp.b - std::abs(l.y)) * kGableSlope : s.height;  // ridge along u
      const int kr = v.k_of(base + roof);
      if (side || end) {
        double top = roof + (s.parapet ? kParapet : 0.0);
        if (s.gable && side) top = eave;  // eave walls; the end walls rise into the gable
        v.put_column(i, j, k0, v.k_of(base + top), kBuilding);
      } else {
        v.put_column(i, j, s.gable ? kr - 1 : kr, kr, kBuilding);  // pitched roofs two voxels thick
      }
    }
}

void voxelise_tree(ChunkVolume& v, const glm::dvec2& p, double base, uint64_t key) {
  const TreeShape t = tree_shape(key);
  // trunk r 0.2 m reaching half way into the crown; the crown's bottom 0.3 rz below the trunk's bare top
  voxelise_cylinder(v, p, 0.2, base, base + t.trunk + 0.5 * t.rz, static_cast<uint8_t>(SemanticClass::TreeTrunk));
  voxelise_ellipsoid(v, glm::dvec3(p, base + t.trunk + 0.7 * t.rz), t.r, t.rz, kCanopyShell, kCanopyWobble,
                     hash_mix(key, kSaltCrown), static_cast<uint8_t>(SemanticClass::Vegetation));
}

}  // namespace icube::world::procedural
