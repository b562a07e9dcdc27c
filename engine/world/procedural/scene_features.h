// Scene-wide data of the procedural prior, computed once in its constructor
// and read-only afterwards (generate() is const and runs on several threads):
// the road surface (0.2 m, segment barriers), the ground-height function,
// road lines with arc length and dash pattern, crosswalk and driveway
// polygons, junction corners with traffic lights or stop-sign posts, and the
// road edges' samples with outward normals. Nothing here depends on the seed.
#pragma once

#include "scene/scene.h"
#include "world/procedural/procedural_prior.h"
#include "world/procedural/segment_index.h"
#include "world/road_surface.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <unordered_map>
#include <vector>

namespace icube::world::procedural {

// Band widths shared by the scene precompute and the chunk rules.
inline constexpr double kCurbWidth = 0.3;        // curb band just outside the drivable area
inline constexpr double kSidewalkWavelength = 50.0;  // sidewalk width changes over ~ a block face
inline constexpr double kSetbackWavelength = 70.0;   // front-yard depth changes more slowly
// Noise salts (arbitrary distinct constants: one per independent random quantity).
enum Salt : uint64_t {
  kSaltSidewalk = 11, kSaltSetback, kSaltStreetTree, kSaltPark, kSaltLightPhase, kSaltParcel, kSaltParcelOffset,
  kSaltBush, kSaltHedge,
};

struct MarkLine {
  std::vector<glm::dvec2> pts;  // consecutive duplicates removed
  std::vector<double> s;        // arc length at each point
  glm::dvec2 lo{0.0}, hi{0.0};  // bounding box
  int count = 1;                // 1 or 2 (double line)
  bool dashed[2] = {false, false};
  double phase = 0.0;           // dash phase (m)
};

struct MapPolygon {
  std::vector<glm::dvec2> pts;
  glm::dvec2 lo{0.0}, hi{0.0};
  glm::dvec2 axis{1.0, 0.0};  // crosswalks: direction of the longest edge (stripes repeat along it)
  bool contains(const glm::dvec2& p) const;
};

// A post beside the road: position, outward normal (away from the road), tangent along the road.
struct RoadsidePost {
  glm::dvec2 pos{0.0}, out{1.0, 0.0}, tangent{0.0, 1.0};
};

struct TreeSite {
  glm::dvec2 pos{0.0};
  uint64_t key = 0;  // hash for the tree's shape
};

struct SceneFeatures {
  SceneFeatures(const scene::Scene& scene, const ProceduralOptions& options);

  // Road surface height where a block exists, else the nearest block's plane
  // at the point clamped into that block (searching 3 block rings), else fallback_z.
  using HeightCache = std::unordered_map<uint64_t, int32_t>;  // block lattice cell -> nearest block (-1 none)
  double ground_height(double x, double y, HeightCache* cache = nullptr) const;
  int32_t nearest_block(int bx, int by) const;
  double sidewalk_width(uint64_t seed, double x, double y) const;
  double setback(uint64_t seed, double x, double y) const;

  ProceduralOptions options;
  RoadSurface surface;
  double fallback_z = 0.0;
  std::unordered_map<uint64_t, uint32_t> block_lookup;  // packed block index -> surface.blocks()
  std::vector<MarkLine> lines;
  std::vector<MapPolygon> crosswalks, driveways;
  SegmentIndex roads{8.0};   // road edges + lane centre lines (orientation)
  SegmentIndex ego_path{8.0};  // valid ego positions (clearance)
  std::vector<glm::dvec2> junctions;
  std::vector<RoadsidePost> stop_posts, traffic_lights;
  // Road edges resampled at 0.25 m with their outward normals. Street trees and
  // street lights depend on the request's seed, so generate() places them from
  // these samples (nothing seeded is cached: generate() must stay const).
  struct EdgeSample {
    glm::dvec2 p{0.0}, out{0.0}, tangent{0.0};
    double s = 0.0;
    bool valid = false;  // exactly one side of the edge is drivable
  };
  struct EdgeSamples {
    int64_t id = 0;
    std::vector<EdgeSample> samples;
    glm::dvec2 lo{0.0}, hi{0.0};
  };
  std::vector<EdgeSamples> edges;
};

uint64_t block_key2(int bx, int by);

}  // namespace icube::world::procedural
