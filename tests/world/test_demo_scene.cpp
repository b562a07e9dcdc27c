// The embedded demo scene (engine/world/demo_scene.h): JSON round trip, the
// ego drive (>= 300 m, through the junction, 10 Hz), no two boxes overlapping
// at any time, every moving car on a lane, lane connectivity, and
// assets/demo_scene.json being exactly make_demo_scene() serialised.
#include <doctest/doctest.h>

#include "scene/atomic_file.h"
#include "scene/frames.h"
#include "scene/scene_json.h"
#include "world/chunk_plan.h"
#include "world/demo_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <string>

using namespace icube;

namespace {

const scene::Scene& demo() {
  static const scene::Scene s = world::make_demo_scene();
  return s;
}

using Quad = std::array<glm::dvec2, 4>;

Quad footprint(const scene::BoxState& b) {
  const glm::dvec2 c(b.center), u(std::cos(b.heading), std::sin(b.heading)), v(-u.y, u.x);
  const glm::dvec2 hl = 0.5 * b.length * u, hw = 0.5 * b.width * v;
  return {c + hl + hw, c - hl + hw, c - hl - hw, c + hl - hw};
}

// Separating-axis test on the four edge normals: true when the interiors overlap.
bool overlap(const Quad& a, const Quad& b) {
  for (const Quad* q : {&a, &b})
    for (int e = 0; e < 2; ++e) {
      const glm::dvec2 d = (*q)[static_cast<size_t>(e + 1)] - (*q)[static_cast<size_t>(e)];
      const glm::dvec2 n(-d.y, d.x);
      double amin = std::numeric_limits<double>::infinity(), amax = -amin, bmin = amin, bmax = -amin;
      for (const glm::dvec2& p : a) amin = std::min(amin, glm::dot(p, n)), amax = std::max(amax, glm::dot(p, n));
      for (const glm::dvec2& p : b) bmin = std::min(bmin, glm::dot(p, n)), bmax = std::max(bmax, glm::dot(p, n));
      if (amax <= bmin || bmax <= amin) return false;
    }
  return true;
}

double distance_to_polyline(glm::dvec2 p, const std::vector<glm::dvec3>& pts) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    const glm::dvec2 a(pts[i]), b(pts[i + 1]);
    const glm::dvec2 ab = b - a;
    const double t = std::clamp(glm::dot(p - a, ab) / glm::dot(ab, ab), 0.0, 1.0);
    best = std::min(best, glm::length(p - (a + t * ab)));
  }
  return best;
}

}  // namespace

TEST_CASE("demo scene: contents, provenance and a lossless JSON round trip") {
  const scene::Scene& s = demo();
  CHECK(s.prompt == "a sunny suburban junction");
  CHECK(s.provenance.source_format == "icube-demo");
  REQUIRE(s.cameras.size() == 1);
  CHECK(s.cameras[0].width == scene::kInfiniCubeWidth);
  CHECK(s.map.lanes.size() == 20);
  CHECK(s.map.road_edges.size() == 4);
  CHECK(s.map.crosswalks.size() == 4);
  CHECK(s.map.stop_signs.size() >= 2);
  size_t yellow = 0, white = 0;
  for (const scene::RoadLine& l : s.map.road_lines) {
    yellow += l.type == scene::RoadLineType::SolidSingleYellow;
    white += l.type == scene::RoadLineType::BrokenSingleWhite;
  }
  CHECK(yellow == 4);
  CHECK(white == 8);
  size_t parked = 0, moving = 0, peds = 0;
  for (size_t i = 0; i < s.tracks.size(); ++i) {
    const scene::Track& t = s.tracks[i];
    REQUIRE(t.states.size() == s.timestamps.size());
    if (static_cast<int>(i) == s.sdc_track_index) continue;
    if (t.type == scene::ObjectType::Pedestrian) ++peds;
    if (t.type == scene::ObjectType::Vehicle) ++(t.dynamic ? moving : parked);
  }
  CHECK(parked == 10);
  CHECK(moving == 4);
  CHECK(peds == 2);
  // 10 Hz.
  for (size_t i = 0; i < s.timestamps.size(); ++i) CHECK(s.timestamps[i] == static_cast<double>(i) / 10.0);

  const std::string text = scene::scene_to_json(s);
  CHECK(text.size() < 1000000);
  const scene::Scene back = scene::scene_from_json(text, "demo.json");
  CHECK(scene::scene_to_json(back) == text);
  CHECK(back.tracks.size() == s.tracks.size());
  CHECK(back.ego.size() == s.ego.size());
}

TEST_CASE("demo scene: the ego drives >= 300 m through the junction") {
  const scene::Scene& s = demo();
  REQUIRE(s.ego.size() == s.timestamps.size());
  REQUIRE(s.sdc_track_index == 0);
  double len = 0.0, nearest = 1e9;
  for (size_t i = 0; i < s.ego.size(); ++i) {
    const glm::dvec3 p(s.ego[i].ego_to_world[3]);
    nearest = std::min(nearest, glm::length(glm::dvec2(p) - world::kDemoJunctionCentre));
    if (i > 0) len += glm::length(p - glm::dvec3(s.ego[i - 1].ego_to_world[3]));
    // The SDC box sits on the ego pose, and consecutive poses are at most 12 m/s apart.
    CHECK(glm::length(glm::dvec2(s.tracks[0].states[i].center) - glm::dvec2(p)) < 1e-9);
    if (i > 0) CHECK(glm::length(p - glm::dvec3(s.ego[i - 1].ego_to_world[3])) <= 1.2 + 1e-9);
  }
  CAPTURE(len);
  CAPTURE(nearest);
  CHECK(len >= 300.0);
  CHECK(nearest <= 10.0);
  // The trajectory plan turns with the drive: chunks head east, then north.
  const world::ChunkPlan plan = world::plan_trajectory(s);
  CHECK(plan.chunks.size() >= 9);
  CHECK(std::abs(world::chunk_heading(plan.chunks.front())) < 1e-6);
  CHECK(std::abs(world::chunk_heading(plan.chunks.back()) - 0.5 * 3.141592653589793) < 1e-6);
}

TEST_CASE("demo scene: no two boxes overlap at any time, moving cars stay on lanes") {
  const scene::Scene& s = demo();
  size_t pairs = 0;
  for (size_t t = 0; t < s.timestamps.size(); ++t) {
    std::vector<std::pair<size_t, Quad>> boxes;
    for (size_t i = 0; i < s.tracks.size(); ++i)
      if (s.tracks[i].states[t].valid) boxes.push_back({i, footprint(s.tracks[i].states[t])});
    for (size_t a = 0; a < boxes.size(); ++a)
      for (size_t b = a + 1; b < boxes.size(); ++b) {
        ++pairs;
        if (overlap(boxes[a].second, boxes[b].second)) {
          CAPTURE(t);
          CAPTURE(boxes[a].first);
          CAPTURE(boxes[b].first);
          FAIL_CHECK("boxes overlap");
        }
      }
  }
  CHECK(pairs > 10000);
  // Sanity of the overlap test itself.
  scene::BoxState x;
  x.length = 4.0, x.width = 2.0;
  scene::BoxState y = x;
  y.center = {3.9, 0.0, 0.0};
  CHECK(overlap(footprint(x), footprint(y)));
  y.center = {3.0, 2.1, 0.0};
  CHECK_FALSE(overlap(footprint(x), footprint(y)));

  size_t checked = 0;
  for (const scene::Track& tr : s.tracks) {
    if (tr.type != scene::ObjectType::Vehicle || !tr.dynamic) continue;
    for (const scene::BoxState& b : tr.states) {
      if (!b.valid) continue;
      double best = 1e9;
      for (const scene::Lane& l : s.map.lanes) best = std::min(best, distance_to_polyline(glm::dvec2(b.center), l.points));
      CHECK(best <= 1.0);
      ++checked;
    }
  }
  CHECK(checked > 1000);
}

TEST_CASE("demo scene: lane connectivity is consistent") {
  const scene::Scene& s = demo();
  std::map<int64_t, const scene::Lane*> by_id;
  for (const scene::Lane& l : s.map.lanes) by_id[l.id] = &l;
  for (const scene::Lane& l : s.map.lanes) {
    for (int64_t e : l.exit_lanes) {
      REQUIRE(by_id.count(e) == 1);
      const scene::Lane& n = *by_id[e];
      CHECK(std::count(n.entry_lanes.begin(), n.entry_lanes.end(), l.id) == 1);
      CHECK(glm::length(l.points.back() - n.points.front()) < 1e-3);  // the lanes join
    }
    CHECK(l.exit_lanes.size() + l.entry_lanes.size() > 0);
  }
}

TEST_CASE("demo scene: assets/demo_scene.json is make_demo_scene() serialised") {
  const std::string path = std::string(ICUBE_SOURCE_DIR) + "/assets/demo_scene.json";
  std::string file;
  try {
    file = scene::read_file(path);
  } catch (const std::exception& e) {
    FAIL("cannot read " << path << ": " << e.what() << " (regenerate: icube world demo-scene -o " << path << ")");
  }
  CHECK_MESSAGE(file == scene::scene_to_json(demo()),
                "assets/demo_scene.json is stale; regenerate it with `icube world demo-scene -o assets/demo_scene.json`");
}
