// The procedural prior's per-chunk rules (see chunk_rules.h and
// procedural_prior.h). Every decision about a cell is a function of world
// position, the map and the seed: the raster's margin covers everything a
// decision looks at, so overlapping chunks agree cell for cell.
#include "world/procedural/chunk_rules.h"

#include "world/procedural/bev_raster.h"
#include "world/procedural/chunk_volume.h"
#include "world/chunk_pose.h"
#include "world/procedural/hash_noise.h"
#include "world/procedural/structures.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace icube::world::procedural {

namespace {

using SC = SemanticClass;
constexpr uint8_t id(SC c) { return static_cast<uint8_t>(c); }

// ---- numbers (metres unless noted) ---------------------------------------------------
constexpr double kCropEps = 1e-9;            // crop test slack for centres exactly on a face
constexpr double kLineHalfWidth = 0.12;      // road lines ~0.1-0.15 m wide: one 0.2 m voxel at any angle
constexpr double kDoubleLineOffset = 0.15;   // each stroke of a double line off the polyline (gap shows)
constexpr double kDashOn = 3.0, kDashCycle = 12.0;  // US broken line: 10 ft stroke, 30 ft gap
constexpr double kStripe = 0.55, kStripeCycle = 1.1;  // crosswalk bars 0.55 m, gaps 0.55 m
constexpr double kTreeReach = 4.5;           // canopy radius 3.5 m x (1 + wobble 0.15) + slack
constexpr double kVergeOffset = 0.9;         // street trees ~1 m into the verge beyond the sidewalk
constexpr double kTreeMinSpacing = 4.0;      // street trees closer than this: the one with the lower key stays
constexpr double kTreeSkip = 0.15;           // fraction of street-tree slots left empty
constexpr double kParkInset = 2.0;           // park trees this far inside their parcel
constexpr double kParkTreeSpacing = 3.5;
constexpr double kParcelInset = 0.6;         // buildings this far inside their parcel: >= 1.2 m between houses
constexpr double kBuildingHalfMin = 3.5, kBuildingHalfLen = 8.5, kBuildingHalfDepth = 7.5;  // 7-17 x 7-15 m
constexpr int kBuildingAttempts = 4;
constexpr double kBuildingSlide = 2.0;        // m further back per retry
constexpr double kRoadSearch = 40.0;         // building orientation: nearest road within this
constexpr double kHedgeProbability = 0.3;    // of a parcel's two owned lot lines
constexpr double kHedgeHalfWidth = 0.25;     // hedges ~0.4-0.5 m thick (two or three voxels)
constexpr double kHedgeHeightMin = 0.8, kHedgeHeightMax = 1.4;
constexpr double kEgoClearBuilding = 5.0, kEgoClearTree = 4.0, kEgoClearBush = 2.0;
constexpr double kRaised = 0.2;              // curb, sidewalk and verges one voxel above the road
constexpr double kStopPostHeight = 2.5, kStopPlateHeight = 2.1, kStopPlateRadius = 0.38;
constexpr double kMastHeight = 5.8, kLightHeadHeight = 5.0;
constexpr double kStreetLightHeight = 7.5, kStreetLightOffset = 0.4;

enum Band : uint8_t { kRoad, kCurb, kSidewalk, kWalkable, kOther, kDriveway };

double pos_mod(double x, double m) {
  const double r = std::fmod(x, m);
  return r < 0.0 ? r + m : r;
}

class ChunkBuilder {
 public:
  ChunkBuilder(const SceneFeatures& f, const ChunkRequest& req) : f_(f), req_(req), opt_(f.options) {}
  ChunkVoxels run();

 private:
  void setup();
  void build_raster();
  void paint_markers(std::vector<uint8_t>& marker) const;
  void ground(const std::vector<uint8_t>& marker);
  void parcels();
  void hedges(const glm::dvec2& p0, const glm::dvec2& p1, HashStream hh);
  void street_trees_and_lights();
  void furniture();
  ChunkVoxels emit() const;

  // raster helpers
  Band band_at(const glm::dvec2& p) const {
    const glm::ivec2 c = r_.cell_of(p);
    return r_.in(c.x, c.y) ? static_cast<Band>(band_[r_.index(c.x, c.y)]) : kRoad;  // outside: refuse
  }
  // The height every rule places voxels from: the surface lowered by half a voxel, so that
  // k_of(ground_z) is the cell whose TOP is nearest the surface (a road at z = 0 fills
  // [-0.2, 0], and a car standing on it touches it instead of sinking one voxel deep).
  double ground_z(const glm::dvec2& p) { return f_.ground_height(p.x, p.y, &hcache_) - 0.5 * kFineVoxel; }
  bool ego_clear(const glm::dvec2& p, double r) const { return !f_.ego_path.nearest(p, r).found; }
  void tree(const glm::dvec2& p, uint64_t key) { voxelise_tree(v_, p, ground_z(p) + kRaised, key); }

  const SceneFeatures& f_;
  const ChunkRequest& req_;
  const ProceduralOptions& opt_;
  ChunkPose pose_;
  glm::dmat3 rot_{1.0};
  glm::dvec3 centre_{0.0};
  glm::dvec2 lo_{0.0}, hi_{0.0};  // world x, y bounding box of the crop box
  double margin_ = 0.0;
  BevRaster r_;
  std::vector<uint8_t> band_;
  ChunkVolume v_;
  SceneFeatures::HeightCache hcache_;
};

void ChunkBuilder::setup() {
  if (!req_.plan) throw std::invalid_argument("ProceduralPrior::generate: request has no plan");
  if (req_.chunk >= req_.plan->chunks.size())
    throw std::invalid_argument("ProceduralPrior::generate: chunk index out of range");
  if (!(req_.world_voxel_size > 0.0)) throw std::invalid_argument("ProceduralPrior::generate: bad voxel size");
  pose_ = req_.plan->chunks[req_.chunk];
  rot_ = glm::dmat3(pose_.chunk_to_world);
  centre_ = glm::dvec3(pose_.chunk_to_world[3]);
  glm::dvec3 wlo(1e300), whi(-1e300);
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 q((c & 1 ? 1 : -1) * kChunkHalfExtent.x, (c & 2 ? 1 : -1) * kChunkHalfExtent.y,
                       (c & 4 ? 1 : -1) * kChunkHalfExtent.z);
    const glm::dvec3 p = centre_ + rot_ * q;
    wlo = glm::min(wlo, p), whi = glm::max(whi, p);
  }
  lo_ = glm::dvec2(wlo), hi_ = glm::dvec2(whi);
  const double vs = req_.world_voxel_size;
  const glm::dvec3& o = req_.world_origin;
  auto fl = [](double x) { return static_cast<int>(std::floor(x)); };
  // one cell of slack each way; the crop test decides
  const glm::ivec3 ijk_lo(fl((wlo.x - o.x) / vs) - 1, fl((wlo.y - o.y) / vs) - 1, fl((wlo.z - o.z) / vs) - 1);
  const glm::ivec3 ijk_hi(fl((whi.x - o.x) / vs) + 1, fl((whi.y - o.y) / vs) + 1, fl((whi.z - o.z) / vs) + 1);
  v_.init(o, vs, ijk_lo, ijk_hi);
  // Margin: a parcel touching the region (grown by a canopy's reach) is validated over its
  // whole area, and each validated cell looks up to curb + sidewalk + setback for the road.
  const double reach = kCurbWidth + opt_.sidewalk_width_max + opt_.building_setback_max;
  margin_ = kTreeReach + opt_.parcel_size + reach + 1.0;
  const int mc = static_cast<int>(std::ceil(margin_ / vs));
  r_.origin = glm::dvec2(o), r_.cell = vs;
  r_.ij0 = glm::ivec2(ijk_lo) - mc;
  r_.nx = v_.dim.x + 2 * mc, r_.ny = v_.dim.y + 2 * mc;
}

void ChunkBuilder::build_raster() {
  const size_t n = r_.size();
  std::vector<uint8_t> drive(n, 0);
  for (int y = 0; y < r_.ny; ++y)
    for (int x = 0; x < r_.nx; ++x) {
      const glm::dvec2 c = r_.centre(x, y);
      drive[r_.index(x, y)] = f_.surface.drivable(c.x, c.y) ? 1 : 0;
    }
  const std::vector<float> d2 = squared_distance_transform(drive, r_.nx, r_.ny);
  const double reach = kCurbWidth + opt_.sidewalk_width_max + opt_.building_setback_max;
  band_.assign(n, kOther);
  for (int y = 0; y < r_.ny; ++y)
    for (int x = 0; x < r_.nx; ++x) {
      const size_t i = r_.index(x, y);
      if (drive[i]) {
        band_[i] = kRoad;
        continue;
      }
      const double d = std::sqrt(static_cast<double>(d2[i])) * r_.cell;
      if (d > reach) continue;  // kOther
      if (d <= kCurbWidth) {
        band_[i] = kCurb;
        continue;
      }
      const glm::dvec2 c = r_.centre(x, y);
      const double sw = kCurbWidth + f_.sidewalk_width(req_.seed, c.x, c.y);
      if (d <= sw) band_[i] = kSidewalk;
      else if (d <= sw + f_.setback(req_.seed, c.x, c.y)) band_[i] = kWalkable;
    }
  const glm::dvec2 rlo = r_.centre(0, 0), rhi = r_.centre(r_.nx - 1, r_.ny - 1);
  for (const MapPolygon& pg : f_.driveways) {
    if (pg.hi.x < rlo.x || pg.hi.y < rlo.y || pg.lo.x > rhi.x || pg.lo.y > rhi.y) continue;
    const glm::ivec2 a = glm::max(r_.cell_of(pg.lo), glm::ivec2(0));
    const glm::ivec2 b = glm::min(r_.cell_of(pg.hi), glm::ivec2(r_.nx - 1, r_.ny - 1));
    for (int y = a.y; y <= b.y; ++y)
      for (int x = a.x; x <= b.x; ++x) {
        const size_t i = r_.index(x, y);
        if (!drive[i] && pg.contains(r_.centre(x, y))) band_[i] = kDriveway;
      }
  }
  // the volume's drivable columns
  const glm::ivec2 off = glm::ivec2(v_.lo) - r_.ij0;
  for (int y = 0; y < v_.dim.y; ++y)
    for (int x = 0; x < v_.dim.x; ++x)
      v_.drivable[static_cast<size_t>(x) + static_cast<size_t>(v_.dim.x) * static_cast<size_t>(y)] =
          drive[r_.index(x + off.x, y + off.y)];
}

void ChunkBuilder::paint_markers(std::vector<uint8_t>& marker) const {
  const glm::dvec2 vlo(v_.cx(v_.lo.x), v_.cy(v_.lo.y));
  const glm::dvec2 vhi(v_.cx(v_.lo.x + v_.dim.x - 1), v_.cy(v_.lo.y + v_.dim.y - 1));
  auto mark = [&](int i, int j) {
    if (v_.in_xy(i, j)) marker[v_.column(i, j)] = 1;
  };
  for (const MarkLine& l : f_.lines) {
    if (l.hi.x < vlo.x || l.hi.y < vlo.y || l.lo.x > vhi.x || l.lo.y > vhi.y) continue;
    for (int stroke = 0; stroke < l.count; ++stroke) {
      const double off = l.count == 2 ? (stroke == 0 ? kDoubleLineOffset : -kDoubleLineOffset) : 0.0;
      for (size_t s = 1; s < l.pts.size(); ++s) {
        const glm::dvec2 d = l.pts[s] - l.pts[s - 1];
        const double len = glm::length(d);
        const glm::dvec2 t = d / len, nrm(-t.y, t.x);
        const glm::dvec2 a = l.pts[s - 1] + nrm * off, b = l.pts[s] + nrm * off;
        const glm::dvec2 blo = glm::min(a, b) - kLineHalfWidth, bhi = glm::max(a, b) + kLineHalfWidth;
        if (bhi.x < vlo.x || bhi.y < vlo.y || blo.x > vhi.x || blo.y > vhi.y) continue;
        for (int j = std::max(v_.j_of(blo.y), v_.lo.y); j <= std::min(v_.j_of(bhi.y), v_.lo.y + v_.dim.y - 1); ++j)
          for (int i = std::max(v_.i_of(blo.x), v_.lo.x); i <= std::min(v_.i_of(bhi.x), v_.lo.x + v_.dim.x - 1);
               ++i) {
            const glm::dvec2 p(v_.cx(i), v_.cy(j));
            const double tt = std::clamp(glm::dot(p - a, t), 0.0, len);
            if (glm::length(p - (a + t * tt)) > kLineHalfWidth) continue;
            if (l.dashed[stroke] && pos_mod(l.s[s - 1] + tt + l.phase, kDashCycle) >= kDashOn) continue;
            mark(i, j);
          }
      }
    }
  }
  for (const MapPolygon& pg : f_.crosswalks) {
    if (pg.hi.x < vlo.x || pg.hi.y < vlo.y || pg.lo.x > vhi.x || pg.lo.y > vhi.y) continue;
    for (int j = std::max(v_.j_of(pg.lo.y), v_.lo.y); j <= std::min(v_.j_of(pg.hi.y), v_.lo.y + v_.dim.y - 1); ++j)
      for (int i = std::max(v_.i_of(pg.lo.x), v_.lo.x); i <= std::min(v_.i_of(pg.hi.x), v_.lo.x + v_.dim.x - 1); ++i) {
        const glm::dvec2 p(v_.cx(i), v_.cy(j));
        if (pg.contains(p) && pos_mod(glm::dot(p - pg.pts[0], pg.axis), kStripeCycle) < kStripe) mark(i, j);
      }
  }
}

void ChunkBuilder::ground(const std::vector<uint8_t>& marker) {
  const glm::ivec2 off = glm::ivec2(v_.lo) - r_.ij0;
  static constexpr std::array<uint8_t, 6> kBandClass = {id(SC::Road),     id(SC::Curb),        id(SC::Sidewalk),
                                                        id(SC::Walkable), id(SC::OtherGround), id(SC::Road)};
  for (int y = 0; y < v_.dim.y; ++y)
    for (int x = 0; x < v_.dim.x; ++x) {
      const int i = v_.lo.x + x, j = v_.lo.y + y;
      const Band b = static_cast<Band>(band_[r_.index(x + off.x, y + off.y)]);
      const int k = v_.k_of(ground_z({v_.cx(i), v_.cy(j)}));
      const uint8_t c = kBandClass[b];
      if (b == kRoad) {
        v_.put(i, j, k - 1, c);  // two voxels thick: no holes once the world is viewed rotated
        v_.put(i, j, k, marker[v_.column(i, j)] ? id(SC::LaneMarker) : c);
      } else if (b == kDriveway) {
        v_.put_column(i, j, k - 1, k, c);  // flush with the road (dropped curb)
      } else {
        v_.put_column(i, j, k, k + 1, c);  // raised one voxel
      }
    }
}

// Lot-line hedges: each parcel owns its low-x and low-y boundary lines and
// plants some of them as hedges, only across the lawn (front-yard) band.
void ChunkBuilder::hedges(const glm::dvec2& p0, const glm::dvec2& p1, HashStream hh) {
  for (int axis = 0; axis < 2; ++axis) {
    const bool plant = hh.next() < kHedgeProbability;
    const double height = hh.range(kHedgeHeightMin, kHedgeHeightMax);
    if (!plant) continue;
    const double line = axis == 0 ? p0.x : p0.y;
    const double a = axis == 0 ? p0.y : p0.x, b = axis == 0 ? p1.y : p1.x;  // extent along the line
    const int l0 = axis == 0 ? v_.i_of(line - kHedgeHalfWidth) : v_.j_of(line - kHedgeHalfWidth);
    const int l1 = axis == 0 ? v_.i_of(line + kHedgeHalfWidth) : v_.j_of(line + kHedgeHalfWidth);
    const int m0 = axis == 0 ? v_.j_of(a) : v_.i_of(a), m1 = axis == 0 ? v_.j_of(b) : v_.i_of(b);
    for (int l = l0; l <= l1; ++l)
      for (int m = m0; m <= m1; ++m) {
        const int i = axis == 0 ? l : m, j = axis == 0 ? m : l;
        if (!v_.in_xy(i, j)) continue;
        const glm::dvec2 c(v_.cx(i), v_.cy(j));
        const double across = axis == 0 ? c.x - line : c.y - line, along = axis == 0 ? c.y : c.x;
        if (std::abs(across) > kHedgeHalfWidth || along < a || along >= b || band_at(c) != kWalkable) continue;
        const double base = ground_z(c) + kRaised;
        v_.put_column(i, j, v_.k_of(base) + 1, v_.k_of(base + height), id(SC::Vegetation));
      }
  }
}

void ChunkBuilder::parcels() {
  const double ps = opt_.parcel_size;
  const glm::dvec2 poff(hash_u01(req_.seed, kSaltParcelOffset, 0) * ps, hash_u01(req_.seed, kSaltParcelOffset, 1) * ps);
  const glm::dvec2 glo = lo_ - kTreeReach, ghi = hi_ + kTreeReach;
  const auto px0 = static_cast<int64_t>(std::floor((glo.x - poff.x) / ps)), px1 = static_cast<int64_t>(std::floor((ghi.x - poff.x) / ps));
  const auto py0 = static_cast<int64_t>(std::floor((glo.y - poff.y) / ps)), py1 = static_cast<int64_t>(std::floor((ghi.y - poff.y) / ps));
  for (int64_t py = py0; py <= py1; ++py)
    for (int64_t px = px0; px <= px1; ++px) {
      const glm::dvec2 p0 = poff + glm::dvec2(double(px), double(py)) * ps, p1 = p0 + ps;
      const glm::dvec2 pc = 0.5 * (p0 + p1);
      HashStream hs(hash_of(req_.seed, kSaltParcel, px, py));
      bool built = false;
      Footprint fp;
      if (opt_.buildings && hs.next() < opt_.building_probability) {
        const auto road = f_.roads.nearest(pc, kRoadSearch);
        fp.u = road.found ? road.dir : glm::dvec2(1.0, 0.0);
        fp.w = glm::dvec2(-fp.u.y, fp.u.x);
        // away from the road: retries slide the house towards the back of the lot
        const glm::dvec2 away = road.found && glm::length(pc - road.point) > 1e-6 ? glm::normalize(pc - road.point)
                                                                                  : glm::dvec2(0.0);
        for (int attempt = 0; attempt < kBuildingAttempts && !built; ++attempt) {
          const double scale = 1.0 - 0.15 * attempt;  // each retry smaller
          fp.a = std::max(kBuildingHalfMin, hs.range(kBuildingHalfMin, kBuildingHalfLen) * scale);
          fp.b = std::max(kBuildingHalfMin, hs.range(kBuildingHalfMin, kBuildingHalfDepth) * scale);
          // centre jittered by up to 15 % of the parcel, then slid back per retry
          fp.c = pc + glm::dvec2(hs.range(-0.15, 0.15), hs.range(-0.15, 0.15)) * ps + away * (kBuildingSlide * attempt);
          bool ok = true;
          for (int c = 0; c < 4 && ok; ++c) {
            const glm::dvec2 q = fp.c + fp.u * ((c & 1) ? fp.a : -fp.a) + fp.w * ((c & 2) ? fp.b : -fp.b);
            ok = q.x >= p0.x + kParcelInset && q.y >= p0.y + kParcelInset && q.x <= p1.x - kParcelInset &&
                 q.y <= p1.y - kParcelInset;
          }
          if (!ok) continue;
          if (!ego_clear(fp.c, std::sqrt(fp.a * fp.a + fp.b * fp.b) + kEgoClearBuilding)) continue;
          const double ext = std::sqrt(fp.a * fp.a + fp.b * fp.b);
          const glm::ivec2 a = r_.cell_of(fp.c - ext), b = r_.cell_of(fp.c + ext);
          for (int y = a.y; y <= b.y && ok; ++y)
            for (int x = a.x; x <= b.x && ok; ++x) {
              const glm::dvec2 c = r_.centre(x, y);
              if (!fp.contains(c)) continue;
              ok = r_.in(x, y) && band_[r_.index(x, y)] == kOther;  // beyond sidewalk + setback, off roads
            }
          built = ok;
        }
        if (built) voxelise_building(v_, fp, building_style(hs, opt_, fp), ground_z(fp.c));
      }
      HashStream ht(hash_of(req_.seed, kSaltPark, px, py));
      if (!built && opt_.trees && ht.next() < opt_.park_probability) {
        const int n = 3 + static_cast<int>(ht.next() * 5.0);  // 3-7 trees: a pocket park
        std::vector<glm::dvec2> placed;
        for (int t = 0; t < n; ++t) {
          const glm::dvec2 q(ht.range(p0.x + kParkInset, p1.x - kParkInset), ht.range(p0.y + kParkInset, p1.y - kParkInset));
          const uint64_t key = hash_of(req_.seed, kSaltPark, px, py, t + 1);
          const Band b = band_at(q);
          if (b != kWalkable && b != kOther) continue;
          bool near = false;
          for (const auto& o : placed) near = near || glm::length(o - q) < kParkTreeSpacing;
          if (near || !ego_clear(q, kEgoClearTree)) continue;
          placed.push_back(q);
          tree(q, key);
        }
      }
      if (opt_.trees) hedges(p0, p1, HashStream(hash_of(req_.seed, kSaltHedge, px, py)));
      HashStream hb(hash_of(req_.seed, kSaltBush, px, py));
      if (opt_.trees) {
        const int n = static_cast<int>(hb.next() * 5.0);  // 0-4 shrubs on the lawns of a parcel
        for (int t = 0; t < n; ++t) {
          const glm::dvec2 q(hb.range(p0.x, p1.x), hb.range(p0.y, p1.y));
          const double r = hb.range(0.5, 1.1), rz = hb.range(0.5, 0.9);  // shrubs 1-2.2 m wide, 1-1.8 m tall
          // lawns only, 0.3 m clear of the house; the shrub sits 0.2 rz in the ground
          if (band_at(q) != kWalkable || (built && fp.contains(q, r + 0.3)) || !ego_clear(q, kEgoClearBush)) continue;
          const double base = ground_z(q) + kRaised;
          voxelise_ellipsoid(v_, glm::dvec3(q, base + 0.8 * rz), r, rz, 0.0, 0.0, 0, id(SC::Vegetation));
        }
      }
    }
}

void ChunkBuilder::street_trees_and_lights() {
  struct Cand {
    glm::dvec2 p;
    uint64_t key;
  };
  std::vector<Cand> cands;
  const glm::dvec2 glo = lo_ - kTreeReach - kTreeMinSpacing, ghi = hi_ + kTreeReach + kTreeMinSpacing;
  const double sp = opt_.street_tree_spacing;
  const double reach = kCurbWidth + opt_.sidewalk_width_max + kVergeOffset;
  for (const auto& es : f_.edges) {
    if (es.samples.empty() || es.hi.x < glo.x - reach || es.hi.y < glo.y - reach || es.lo.x > ghi.x + reach ||
        es.lo.y > ghi.y + reach)
      continue;
    const double len = es.samples.back().s;
    auto sample_at = [&](double s) -> const SceneFeatures::EdgeSample& {
      const auto it = std::lower_bound(es.samples.begin(), es.samples.end(), s,
                                       [](const SceneFeatures::EdgeSample& a, double v) { return a.s < v; });
      return it == es.samples.end() ? es.samples.back() : *it;
    };
    if (opt_.trees && sp > 0.0) {
      const double phase = hash_u01(req_.seed, kSaltStreetTree, es.id, -1) * sp;
      for (int64_t k = 0; phase + double(k) * sp <= len; ++k) {
        const uint64_t key = hash_of(req_.seed, kSaltStreetTree, es.id, k);
        HashStream h(key);
        const double s = phase + double(k) * sp + h.range(-0.25, 0.25) * sp;  // jitter a quarter slot
        if (h.next() < kTreeSkip || s < 0.0 || s > len) continue;
        const auto& smp = sample_at(s);
        if (!smp.valid) continue;
        const glm::dvec2 p =
            smp.p + smp.out * (kCurbWidth + f_.sidewalk_width(req_.seed, smp.p.x, smp.p.y) + kVergeOffset);
        if (p.x < glo.x || p.y < glo.y || p.x > ghi.x || p.y > ghi.y) continue;
        const Band b = band_at(p);
        if ((b != kWalkable && b != kOther) || !ego_clear(p, kEgoClearTree)) continue;
        cands.push_back({p, key});
      }
    }
    if (opt_.street_furniture && opt_.street_light_spacing > 0.0) {
      const double lsp = opt_.street_light_spacing;
      const double phase = hash_u01(req_.seed, kSaltLightPhase, es.id) * lsp;
      for (int64_t k = 0; phase + double(k) * lsp <= len; ++k) {
        const auto& smp = sample_at(phase + double(k) * lsp);
        if (!smp.valid) continue;
        const glm::dvec2 p = smp.p + smp.out * (kCurbWidth + kStreetLightOffset);
        if (p.x < lo_.x - 1.0 || p.y < lo_.y - 1.0 || p.x > hi_.x + 1.0 || p.y > hi_.y + 1.0) continue;
        if (f_.surface.drivable(p.x, p.y)) continue;
        const double base = ground_z(p) + kRaised;
        voxelise_cylinder(v_, p, 0.1, base, base + kStreetLightHeight, id(SC::Pole));  // r 0.1 m mast
        // lamp head: a short arm over the curb side
        voxelise_box(v_, glm::dvec3(p - smp.out * 0.3, base + kStreetLightHeight), smp.out, {0.35, 0.15, 0.1},  // 0.7 m luminaire
                     id(SC::Pole));
      }
    }
  }
  for (const Cand& c : cands) {
    if (c.p.x < lo_.x - kTreeReach || c.p.y < lo_.y - kTreeReach || c.p.x > hi_.x + kTreeReach ||
        c.p.y > hi_.y + kTreeReach)
      continue;
    bool beaten = false;
    for (const Cand& o : cands)
      beaten = beaten || (o.key < c.key && glm::length(o.p - c.p) < kTreeMinSpacing);
    if (!beaten) tree(c.p, c.key);
  }
}

void ChunkBuilder::furniture() {
  if (!opt_.street_furniture) return;
  auto near = [&](const glm::dvec2& p) {
    constexpr double kReach = 2.0;  // furniture reaches < 1 m from its post
    return p.x >= lo_.x - kReach && p.y >= lo_.y - kReach && p.x <= hi_.x + kReach && p.y <= hi_.y + kReach;
  };
  for (const RoadsidePost& s : f_.stop_posts) {
    if (!near(s.pos) || f_.surface.drivable(s.pos.x, s.pos.y)) continue;
    const double base = ground_z(s.pos) + kRaised;
    // a 0.08 m post; the plate 0.1 m in front of it, facing along the road (the approaching traffic)
    voxelise_cylinder(v_, s.pos, 0.04, base, base + kStopPostHeight, id(SC::Pole));
    voxelise_plate(v_, glm::dvec3(s.pos + s.tangent * 0.1, base + kStopPlateHeight), s.tangent, kStopPlateRadius,
                   id(SC::Sign));
  }
  for (const RoadsidePost& t : f_.traffic_lights) {
    if (!near(t.pos) || f_.surface.drivable(t.pos.x, t.pos.y)) continue;
    const double base = ground_z(t.pos) + kRaised;
    // mast r 0.12 m; a 0.8 m arm towards the road; a 0.36 x 0.36 x 0.9 m head hanging 0.7 m out (still off the road)
    voxelise_cylinder(v_, t.pos, 0.12, base, base + kMastHeight, id(SC::Pole));
    voxelise_box(v_, glm::dvec3(t.pos - t.out * 0.4, base + kMastHeight - 0.2), t.out, {0.4, 0.1, 0.1}, id(SC::Pole));
    voxelise_box(v_, glm::dvec3(t.pos - t.out * 0.7, base + kLightHeadHeight), t.out, {0.18, 0.18, 0.45},
                 id(SC::TrafficLight));
  }
}

ChunkVoxels ChunkBuilder::emit() const {
  ChunkVoxels out;
  out.lattice_to_world = glm::dmat4(1.0);
  out.lattice_to_world[3] = glm::dvec4(req_.world_origin, 1.0);
  out.voxel_size = v_.vs;
  const glm::dmat3 rt = glm::transpose(rot_);
  const size_t plane = static_cast<size_t>(v_.dim.x) * static_cast<size_t>(v_.dim.y);
  for (int z = 0; z < v_.dim.z; ++z)
    for (int y = 0; y < v_.dim.y; ++y) {
      const uint8_t* row = v_.cls.data() + plane * static_cast<size_t>(z) + static_cast<size_t>(v_.dim.x) * static_cast<size_t>(y);
      for (int x = 0; x < v_.dim.x; ++x) {
        if (x + 8 <= v_.dim.x && (x & 7) == 0) {  // skip empty runs 8 cells at a time (most of the volume is air)
          uint64_t word = 0;
          std::memcpy(&word, row + x, sizeof word);
          if (word == 0) {
            x += 7;
            continue;
          }
        }
        if (!row[x]) continue;
        const glm::ivec3 ijk(v_.lo.x + x, v_.lo.y + y, v_.lo.z + z);
        const glm::dvec3 p(v_.cx(ijk.x), v_.cy(ijk.y), v_.cz(ijk.z));
        const glm::dvec3 q = rt * (p - centre_);
        if (std::abs(q.x) > kChunkHalfExtent.x + kCropEps || std::abs(q.y) > kChunkHalfExtent.y + kCropEps ||
            std::abs(q.z) > kChunkHalfExtent.z + kCropEps)
          continue;
        out.voxels.push_back({ijk, row[x], 0});
      }
    }
  return out;
}

ChunkVoxels ChunkBuilder::run() {
  setup();
  build_raster();
  std::vector<uint8_t> marker(v_.drivable.size(), 0);
  paint_markers(marker);
  ground(marker);
  parcels();
  street_trees_and_lights();
  furniture();
  return emit();
}

}  // namespace

ChunkVoxels generate_chunk(const SceneFeatures& features, const ChunkRequest& request) {
  return ChunkBuilder(features, request).run();
}

}  // namespace icube::world::procedural
