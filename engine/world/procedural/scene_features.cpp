// Scene-wide precompute of the procedural prior (see scene_features.h).
#include "world/procedural/scene_features.h"

#include "world/polyline_resample.h"
#include "world/procedural/hash_noise.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace icube::world::procedural {

namespace {

// m: probe each side of a road edge for drivable cells; the farther probes bridge strips the
// road surface leaves out next to an edge (a block without lane points is never built)
constexpr double kSideProbes[] = {0.6, 1.5, 3.0};
constexpr double kJunctionCluster = 25.0; // m: junction points closer than this to a cluster seed join it
constexpr double kCornerReach = 12.0;     // m: corner apexes within junction radius + this
constexpr double kCornerDedup = 3.0;      // m: corners closer than this are one corner
constexpr double kStopToCorner = 15.0;    // m: a stop sign within this of a corner claims it
constexpr double kStopToEdge = 12.0;      // m: stop-sign posts move to the nearest edge within this
constexpr double kStopPostOffset = 0.5;   // m beyond the curb: on the sidewalk
constexpr double kLightMastOffset = 1.0;  // m beyond the curb: traffic-light mast on the sidewalk
constexpr double kDoubleLineOffset = 0.15;  // m: half the spacing of a double line's two strokes

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
  return v[m];
}

void bbox(const std::vector<glm::dvec2>& pts, glm::dvec2& lo, glm::dvec2& hi) {
  lo = glm::dvec2(std::numeric_limits<double>::max()), hi = -lo;
  for (const auto& p : pts) lo = glm::min(lo, p), hi = glm::max(hi, p);
}

bool finite2(const glm::dvec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

std::vector<glm::dvec2> dedup2(const std::vector<glm::dvec3>& in) {
  std::vector<glm::dvec2> out;
  for (const auto& p : in) {
    if (!finite2(p)) continue;
    const glm::dvec2 q(p);
    if (out.empty() || glm::length(q - out.back()) > 1e-6) out.push_back(q);
  }
  return out;
}

// Strokes of a road line type: count and which are broken.
void line_style(scene::RoadLineType t, MarkLine& l) {
  using T = scene::RoadLineType;
  switch (t) {
    case T::BrokenSingleWhite:
    case T::BrokenSingleYellow: l.count = 1, l.dashed[0] = true; break;
    case T::SolidDoubleWhite:
    case T::SolidDoubleYellow: l.count = 2; break;
    case T::BrokenDoubleYellow: l.count = 2, l.dashed[0] = l.dashed[1] = true; break;
    case T::PassingDoubleYellow: l.count = 2, l.dashed[1] = true; break;
    default: l.count = 1; break;  // solid single, unknown
  }
}

}  // namespace

uint64_t block_key2(int bx, int by) {
  return (static_cast<uint64_t>(static_cast<uint32_t>(bx)) << 32) | static_cast<uint32_t>(by);
}

bool MapPolygon::contains(const glm::dvec2& p) const {
  if (p.x < lo.x || p.y < lo.y || p.x > hi.x || p.y > hi.y) return false;
  bool in = false;
  for (size_t i = 0, j = pts.size() - 1; i < pts.size(); j = i++) {
    const glm::dvec2 a = pts[i], b = pts[j];
    if ((a.y > p.y) != (b.y > p.y) && p.x < (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x) in = !in;
  }
  return in;
}

SceneFeatures::SceneFeatures(const scene::Scene& scene, const ProceduralOptions& opts) : options(opts) {
  const scene::Map& map = scene.map;
  RoadSurfaceOptions so;
  so.cell = kFineVoxel;  // one surface cell per voxel column
  so.barrier_segments = true;  // the 0.25 m edge points would leak through 0.2 m cells
  so.seed_margin = 10.0;  // roads reaching over a 40 m block border into a block without lane points stay drivable
  surface = build_road_surface(map, so);
  for (uint32_t i = 0; i < surface.blocks().size(); ++i) {
    const SurfaceBlock& b = surface.blocks()[i];
    block_lookup.emplace(block_key2(b.block.x, b.block.y), i);
  }

  // Fallback height: median lane z, else road edges, else road lines, else the first valid ego pose.
  auto median_of = [](const auto& features) {
    std::vector<double> z;
    for (const auto& f : features)
      for (const auto& p : f.points)
        if (finite2(p)) z.push_back(p.z);
    return median(std::move(z));
  };
  fallback_z = median_of(map.lanes);
  if (std::isnan(fallback_z)) fallback_z = median_of(map.road_edges);
  if (std::isnan(fallback_z)) fallback_z = median_of(map.road_lines);
  if (std::isnan(fallback_z)) {
    fallback_z = 0.0;
    for (const auto& e : scene.ego)
      if (e.valid && std::isfinite(e.ego_to_world[3].z)) {
        fallback_z = e.ego_to_world[3].z;
        break;
      }
  }

  for (const auto& rl : map.road_lines) {
    MarkLine l;
    l.pts = dedup2(rl.points);
    if (l.pts.size() < 2) continue;  // a single point paints nothing
    line_style(rl.type, l);
    l.s.assign(l.pts.size(), 0.0);
    for (size_t i = 1; i < l.pts.size(); ++i) l.s[i] = l.s[i - 1] + glm::length(l.pts[i] - l.pts[i - 1]);
    bbox(l.pts, l.lo, l.hi);
    const double pad = kDoubleLineOffset + 0.2;
    l.lo -= pad, l.hi += pad;
    l.phase = to_unit(splitmix64(static_cast<uint64_t>(rl.id))) * 12.0;  // per-line offset of the 12 m dash cycle
    lines.push_back(std::move(l));
  }
  auto polys = [](const std::vector<scene::Polygon>& in, std::vector<MapPolygon>& out) {
    for (const auto& pg : in) {
      MapPolygon m;
      m.pts = dedup2(pg.points);
      if (m.pts.size() >= 2 && glm::length(m.pts.front() - m.pts.back()) <= 1e-6) m.pts.pop_back();
      if (m.pts.size() < 3) continue;
      bbox(m.pts, m.lo, m.hi);
      double best = 0.0;
      for (size_t i = 0; i < m.pts.size(); ++i) {
        const glm::dvec2 d = m.pts[(i + 1) % m.pts.size()] - m.pts[i];
        if (glm::length(d) > best) best = glm::length(d), m.axis = d / best;
      }
      out.push_back(std::move(m));
    }
  };
  polys(map.crosswalks, crosswalks);
  polys(map.driveways, driveways);

  for (const auto& e : map.road_edges) roads.add_polyline(e.points);
  for (const auto& l : map.lanes) roads.add_polyline(l.points);
  {
    std::vector<glm::dvec3> path;
    for (const auto& e : scene.ego)
      if (e.valid && finite2(glm::dvec3(e.ego_to_world[3]))) path.push_back(glm::dvec3(e.ego_to_world[3]));
    if (path.size() == 1) path.push_back(path.front() + glm::dvec3(1e-3, 0.0, 0.0));  // a parked ego still blocks
    ego_path.add_polyline(path);
  }

  // Road-edge samples and their outward normals (the side that is not drivable).
  for (const auto& e : map.road_edges) {
    std::vector<glm::dvec3> clean;
    for (const auto& p : e.points)
      if (finite2(p)) clean.push_back(p);
    const std::vector<glm::dvec3> rs = resample_polyline(clean, kMapResampleStep);
    EdgeSamples es;
    es.id = e.id;
    std::vector<glm::dvec2> pts;
    for (const auto& p : rs) pts.push_back(glm::dvec2(p));
    double s = 0.0;
    for (size_t i = 0; i < pts.size(); ++i) {
      EdgeSample smp;
      if (i > 0) s += glm::length(pts[i] - pts[i - 1]);
      smp.p = pts[i], smp.s = s;
      const glm::dvec2 t = pts[std::min(i + 1, pts.size() - 1)] - pts[i > 0 ? i - 1 : 0];
      if (glm::length(t) > 1e-6) {
        smp.tangent = glm::normalize(t);
        const glm::dvec2 left(-smp.tangent.y, smp.tangent.x);
        bool dl = false, dr = false;
        for (double d : kSideProbes) {
          const glm::dvec2 pl = smp.p + left * d, pr = smp.p - left * d;
          dl = dl || surface.drivable(pl.x, pl.y), dr = dr || surface.drivable(pr.x, pr.y);
        }
        if (dl != dr) smp.valid = true, smp.out = dl ? -left : left;
      }
      es.samples.push_back(smp);
    }
    if (pts.empty()) continue;
    bbox(pts, es.lo, es.hi);
    edges.push_back(std::move(es));
  }

  // Junctions: points of `interpolating` lanes, and the ends of lanes where
  // several lanes fan in or out, clustered greedily in map order.
  std::vector<glm::dvec2> jpts;
  for (const auto& l : map.lanes) {
    std::vector<glm::dvec2> p = dedup2(l.points);
    if (p.empty()) continue;
    if (l.interpolating) jpts.push_back(p[p.size() / 2]);
    if (l.entry_lanes.size() >= 2) jpts.push_back(p.front());
    if (l.exit_lanes.size() >= 2) jpts.push_back(p.back());
  }
  std::vector<glm::dvec2> seeds, sums;
  std::vector<int> counts;
  for (const auto& p : jpts) {
    size_t c = 0;
    while (c < seeds.size() && glm::length(p - seeds[c]) > kJunctionCluster) ++c;
    if (c == seeds.size()) seeds.push_back(p), sums.push_back(glm::dvec2(0.0)), counts.push_back(0);
    sums[c] += p, counts[c] += 1;
  }
  for (size_t c = 0; c < seeds.size(); ++c) junctions.push_back(sums[c] / double(counts[c]));

  // Corners: per junction, each edge's valid sample nearest the centre (within reach).
  std::vector<RoadsidePost> corners;
  for (const auto& jc : junctions) {
    for (const auto& es : edges) {
      const EdgeSample* best = nullptr;
      double bd = kJunctionCluster + kCornerReach;
      for (const auto& smp : es.samples)
        if (smp.valid && glm::length(smp.p - jc) < bd) bd = glm::length(smp.p - jc), best = &smp;
      if (!best) continue;
      bool dup = false;
      for (const auto& c : corners) dup = dup || glm::length(c.pos - best->p) < kCornerDedup;
      if (!dup) corners.push_back({best->p, best->out, best->tangent});
    }
  }
  std::vector<bool> has_stop(corners.size(), false);
  for (const auto& ss : map.stop_signs) {
    if (!finite2(ss.position)) continue;
    const glm::dvec2 sp(ss.position);
    // post: the nearest valid edge sample, moved onto the sidewalk
    const EdgeSample* best = nullptr;
    double bd = kStopToEdge;
    for (const auto& es : edges)
      for (const auto& smp : es.samples)
        if (smp.valid && glm::length(smp.p - sp) < bd) bd = glm::length(smp.p - sp), best = &smp;
    if (best)
      stop_posts.push_back({best->p + best->out * (kCurbWidth + kStopPostOffset), best->out, best->tangent});
    else if (!surface.drivable(sp.x, sp.y))
      stop_posts.push_back({sp, glm::dvec2(1.0, 0.0), glm::dvec2(0.0, 1.0)});
    size_t bc = corners.size();
    double cd = kStopToCorner;
    for (size_t c = 0; c < corners.size(); ++c)
      if (glm::length(corners[c].pos - sp) < cd) cd = glm::length(corners[c].pos - sp), bc = c;
    if (bc < corners.size()) has_stop[bc] = true;
  }
  for (size_t c = 0; c < corners.size(); ++c)
    if (!has_stop[c])
      traffic_lights.push_back(
          {corners[c].pos + corners[c].out * (kCurbWidth + kLightMastOffset), corners[c].out, corners[c].tangent});
}

int32_t SceneFeatures::nearest_block(int bx, int by) const {
  constexpr int kRings = 3;  // 120 m of 40 m blocks: beyond that the map says nothing about the ground
  int32_t best = -1;
  long best_d = 0;
  for (int dy = -kRings; dy <= kRings; ++dy)
    for (int dx = -kRings; dx <= kRings; ++dx) {
      const auto it = block_lookup.find(block_key2(bx + dx, by + dy));
      if (it == block_lookup.end()) continue;
      const long d = long(dx) * dx + long(dy) * dy;
      const auto i = static_cast<int32_t>(it->second);
      if (best < 0 || d < best_d || (d == best_d && i < best)) best = i, best_d = d;
    }
  return best;
}

double SceneFeatures::ground_height(double x, double y, HeightCache* cache) const {
  if (const auto h = surface.height(x, y)) return *h;
  if (surface.empty()) return fallback_z;
  const double bs = surface.options().block_size;
  const int bx = static_cast<int>(std::floor((x - surface.anchor().x) / bs));
  const int by = static_cast<int>(std::floor((y - surface.anchor().y) / bs));
  int32_t bi = -1;
  if (cache) {
    const auto [it, fresh] = cache->try_emplace(block_key2(bx, by), -1);
    if (fresh) it->second = nearest_block(bx, by);
    bi = it->second;
  } else {
    bi = nearest_block(bx, by);
  }
  if (bi < 0) return fallback_z;
  const SurfaceBlock& b = surface.blocks()[static_cast<size_t>(bi)];
  const double cx = std::clamp(x, b.min_corner.x, b.min_corner.x + bs);
  const double cy = std::clamp(y, b.min_corner.y, b.min_corner.y + bs);
  return b.plane.height(cx, cy);
}

double SceneFeatures::sidewalk_width(uint64_t seed, double x, double y) const {
  return options.sidewalk_width_min + (options.sidewalk_width_max - options.sidewalk_width_min) *
                                          value_noise2(seed, kSaltSidewalk, x, y, kSidewalkWavelength);
}

double SceneFeatures::setback(uint64_t seed, double x, double y) const {
  return options.building_setback_min + (options.building_setback_max - options.building_setback_min) *
                                            value_noise2(seed, kSaltSetback, x, y, kSetbackWavelength);
}

}  // namespace icube::world::procedural
