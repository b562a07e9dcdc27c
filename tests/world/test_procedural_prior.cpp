// The procedural world prior (engine/world/procedural/): on the demo town,
// every class it writes appears, drivable columns hold only ROAD and
// LANE_MARKER, every cell lies in its chunk's crop box, results are
// deterministic per seed and overlapping chunks agree cell for cell; a map
// without lanes and degenerate polylines work; a chunk of the real Waymo
// scenario when ../shared/data is present. Prints the demo plan's class
// histogram and per-chunk timing.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/scene_load.h"
#include "world/chunk_plan.h"
#include "world/demo_scene.h"
#include "world/procedural/procedural_prior.h"
#include "world/semantics.h"
#include "world/voxel_grid.h"
#include "world/world_build.h"

#include <array>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_map>

using namespace icube;
using world::ChunkRequest;
using world::ChunkVoxels;
using world::SemanticClass;

namespace {

constexpr double kVs = world::kFineVoxel;

glm::dvec3 lattice_origin(const world::ChunkPlan& plan) {
  return glm::round(world::chunk_centre(plan.chunks.front()) / kVs) * kVs;
}

ChunkRequest request(const scene::Scene& s, const world::ChunkPlan& plan, size_t chunk, uint64_t seed = 7) {
  ChunkRequest r;
  r.scene = &s, r.plan = &plan, r.chunk = chunk, r.world_origin = lattice_origin(plan), r.seed = seed;
  return r;
}

glm::dvec3 centre_of(const ChunkRequest& r, const glm::ivec3& ijk) { return r.world_origin + (glm::dvec3(ijk) + 0.5) * kVs; }

uint64_t pack(const glm::ivec3& p) {
  return (static_cast<uint64_t>(static_cast<uint32_t>(p.x) & 0x1FFFFF)) |
         (static_cast<uint64_t>(static_cast<uint32_t>(p.y) & 0x1FFFFF) << 21) |
         (static_cast<uint64_t>(static_cast<uint32_t>(p.z) & 0x1FFFFF) << 42);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Checks the invariants of one generated chunk; returns the number of violations.
size_t check_chunk(const world::ProceduralPrior& prior, const ChunkRequest& r, const ChunkVoxels& c) {
  size_t bad_lattice = 0, bad_crop = 0, bad_column = 0, bad_class = 0;
  glm::dmat4 want(1.0);
  want[3] = glm::dvec4(r.world_origin, 1.0);
  if (c.lattice_to_world != want || c.voxel_size != kVs) ++bad_lattice;
  const world::ChunkPose& pose = r.plan->chunks[r.chunk];
  for (const auto& v : c.voxels) {
    const glm::dvec3 p = centre_of(r, v.ijk);
    if (!world::inside_chunk(pose, p, 1e-6)) ++bad_crop;
    if (v.class_id < 1 || v.class_id > 22) ++bad_class;
    if (prior.road_surface().drivable(p.x, p.y) && v.class_id != static_cast<uint8_t>(SemanticClass::Road) &&
        v.class_id != static_cast<uint8_t>(SemanticClass::LaneMarker))
      ++bad_column;
  }
  CHECK(bad_lattice == 0);
  CHECK_MESSAGE(bad_crop == 0, bad_crop << " cells outside the crop box");
  CHECK_MESSAGE(bad_column == 0, bad_column << " non-road cells in drivable columns");
  CHECK(bad_class == 0);
  return bad_lattice + bad_crop + bad_column + bad_class;
}

std::string histogram_text(const std::array<uint64_t, world::kNumSemanticClasses>& h) {
  uint64_t total = 0;
  for (uint64_t n : h) total += n;
  std::ostringstream os;
  os << total << " voxels:";
  for (int c = 1; c < world::kNumSemanticClasses; ++c)
    if (h[static_cast<size_t>(c)]) {
      char buf[96];
      std::snprintf(buf, sizeof buf, " %s %.3f%%", world::semantic_class_name(static_cast<uint8_t>(c)),
                    100.0 * double(h[static_cast<size_t>(c)]) / double(total));
      os << buf;
    }
  return os.str();
}

// The plan's chunk whose centre is nearest the demo junction (never the first or last).
size_t junction_chunk(const world::ChunkPlan& plan) {
  size_t best = 1;
  for (size_t k = 1; k + 1 < plan.chunks.size(); ++k)
    if (glm::length(glm::dvec2(world::chunk_centre(plan.chunks[k])) - world::kDemoJunctionCentre) <
        glm::length(glm::dvec2(world::chunk_centre(plan.chunks[best])) - world::kDemoJunctionCentre))
      best = k;
  return best;
}

// Cells inside both chunks' crop boxes are emitted by both, with the same class.
void check_overlap(const world::ProceduralPrior& prior, const scene::Scene& s, const world::ChunkPlan& plan, size_t k0,
                   size_t k1) {
  const ChunkRequest r0 = request(s, plan, k0), r1 = request(s, plan, k1);
  const ChunkVoxels c0 = prior.generate(r0), c1 = prior.generate(r1);
  std::unordered_map<uint64_t, uint8_t> m0, m1;
  for (const auto& v : c0.voxels) m0.emplace(pack(v.ijk), v.class_id);
  for (const auto& v : c1.voxels) m1.emplace(pack(v.ijk), v.class_id);
  size_t shared = 0, disagree = 0, missing = 0;
  for (const auto& v : c1.voxels) {
    if (!world::inside_chunk(plan.chunks[k0], centre_of(r1, v.ijk), -1e-6)) continue;
    const auto it = m0.find(pack(v.ijk));
    if (it == m0.end()) ++missing;
    else if (++shared, it->second != v.class_id) ++disagree;
  }
  for (const auto& v : c0.voxels)
    if (world::inside_chunk(plan.chunks[k1], centre_of(r0, v.ijk), -1e-6) && !m1.count(pack(v.ijk))) ++missing;
  CHECK(shared > 10000);
  CHECK_MESSAGE(disagree == 0, "chunks " << k0 << "/" << k1 << ": " << disagree << " of " << shared << " differ");
  CHECK_MESSAGE(missing == 0, "chunks " << k0 << "/" << k1 << ": " << missing << " cells only in one");
}

const scene::Scene& demo() {
  static const scene::Scene s = world::make_demo_scene();
  return s;
}

}  // namespace

TEST_CASE("procedural prior: demo chunks hold every class, road columns stay clear, cells stay in the crop box") {
  const scene::Scene& s = demo();
  const world::ProceduralPrior prior(s);
  CHECK(prior.name() == "procedural");
  REQUIRE_FALSE(prior.road_surface().empty());
  const world::ChunkPlan plan = world::plan_trajectory(s);
  REQUIRE(plan.chunks.size() >= 3);
  world::VoxelGrid grid(lattice_origin(plan), kVs);
  // the chunk nearest the junction and its neighbours: the west arm, the junction and the turn north
  const size_t j = junction_chunk(plan);
  for (size_t k = j - 1; k <= j + 1; ++k) {
    const ChunkRequest r = request(s, plan, k);
    const ChunkVoxels c = prior.generate(r);
    CHECK(c.voxels.size() > 100000);
    check_chunk(prior, r, c);
    for (const auto& v : c.voxels)
      if (!grid.contains(v.ijk)) grid.set(v.ijk, v.class_id, v.instance);
  }
  const auto h = grid.class_histogram();
  for (SemanticClass c : {SemanticClass::Road, SemanticClass::LaneMarker, SemanticClass::Curb, SemanticClass::Sidewalk,
                          SemanticClass::Walkable, SemanticClass::OtherGround, SemanticClass::Building,
                          SemanticClass::Vegetation, SemanticClass::TreeTrunk, SemanticClass::Pole, SemanticClass::Sign,
                          SemanticClass::TrafficLight})
    CHECK_MESSAGE(h[static_cast<size_t>(c)] > 0, "missing class " << std::string(world::semantic_class_name(static_cast<uint8_t>(c))));
  MESSAGE("demo chunks " << j - 1 << "-" << j + 1 << ": " << histogram_text(h));
}

TEST_CASE("procedural prior: deterministic per seed, overlapping chunks agree") {
  const scene::Scene& s = demo();
  const world::ProceduralPrior prior(s);
  const world::ChunkPlan plan = world::plan_trajectory(s);
  REQUIRE(plan.chunks.size() >= 3);
  const ChunkVoxels a = prior.generate(request(s, plan, 1, 7));
  const ChunkVoxels b = prior.generate(request(s, plan, 1, 7));
  REQUIRE(a.voxels.size() == b.voxels.size());
  bool same = true;
  for (size_t i = 0; i < a.voxels.size(); ++i)
    same = same && a.voxels[i].ijk == b.voxels[i].ijk && a.voxels[i].class_id == b.voxels[i].class_id &&
           a.voxels[i].instance == b.voxels[i].instance;
  CHECK(same);
  const ChunkVoxels other = prior.generate(request(s, plan, 1, 8));
  bool differs = other.voxels.size() != a.voxels.size();
  for (size_t i = 0; !differs && i < a.voxels.size(); ++i)
    differs = a.voxels[i].ijk != other.voxels[i].ijk || a.voxels[i].class_id != other.voxels[i].class_id;
  CHECK(differs);

  // Thread safety: two chunks generated concurrently equal the sequential results.
  {
    ChunkVoxels t1, t2;
    std::thread th([&] { t1 = prior.generate(request(s, plan, 1, 7)); });
    t2 = prior.generate(request(s, plan, 2, 7));
    th.join();
    const ChunkVoxels s2 = prior.generate(request(s, plan, 2, 7));
    CHECK(t1.voxels.size() == a.voxels.size());
    bool eq = t2.voxels.size() == s2.voxels.size();
    for (size_t i = 0; eq && i < s2.voxels.size(); ++i)
      eq = t2.voxels[i].ijk == s2.voxels[i].ijk && t2.voxels[i].class_id == s2.voxels[i].class_id;
    CHECK(eq);
  }

  // Consecutive chunks overlap (38.4 m stride, 51.2 m chunks); the pairs around the junction
  // are rotated against each other (the ego turns left there).
  const size_t j = junction_chunk(plan);
  for (size_t k = j - 1; k <= j; ++k) check_overlap(prior, s, plan, k, k + 1);
}

TEST_CASE("procedural prior: class histogram and timing of the demo plan (trajectory mode)") {
  const scene::Scene& s = demo();
  auto t0 = std::chrono::steady_clock::now();
  const world::ProceduralPrior prior(s);
  const double setup_s = seconds_since(t0);
  const world::ChunkPlan plan = world::plan_trajectory(s);
  world::VoxelGrid grid(lattice_origin(plan), kVs);
  double worst = 0.0, total = 0.0, cpu = 0.0;
  size_t voxels = 0;
  for (size_t k = 0; k < plan.chunks.size(); ++k) {
    const ChunkRequest r = request(s, plan, k);
    t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();  // process CPU time: the wall clock suffers on a loaded machine
    const ChunkVoxels c = prior.generate(r);
    cpu += double(std::clock() - c0) / CLOCKS_PER_SEC;
    const double dt = seconds_since(t0);
    worst = std::max(worst, dt), total += dt, voxels += c.voxels.size();
    for (const auto& v : c.voxels)
      if (!grid.contains(v.ijk)) grid.set(v.ijk, v.class_id, v.instance);  // existing wins, as fusion does
  }
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "setup %.0f ms; %zu chunks, per chunk %.0f ms wall (worst %.0f), %.0f ms CPU, %.0f k voxels",
                1e3 * setup_s, plan.chunks.size(), 1e3 * total / double(plan.chunks.size()), 1e3 * worst,
                1e3 * cpu / double(plan.chunks.size()), 1e-3 * double(voxels) / double(plan.chunks.size()));
  MESSAGE(buf);
  MESSAGE("demo world: " << histogram_text(grid.class_histogram()));
  CHECK(grid.voxel_count() > 1000000);
}

TEST_CASE("procedural prior: blocks-mode chunks") {
  const scene::Scene& s = demo();
  const world::ProceduralPrior prior(s);
  const world::ChunkPlan plan = world::plan_blocks(s);
  REQUIRE(plan.chunks.size() >= 3);
  // the block nearest the junction and two more: translation-only chunks
  size_t best = 0;
  for (size_t k = 0; k < plan.chunks.size(); ++k)
    if (glm::length(glm::dvec2(world::chunk_centre(plan.chunks[k]))) <
        glm::length(glm::dvec2(world::chunk_centre(plan.chunks[best]))))
      best = k;
  for (size_t k : {best, size_t(0), plan.chunks.size() - 1}) {
    const ChunkRequest r = request(s, plan, k);
    const ChunkVoxels c = prior.generate(r);
    CHECK(c.voxels.size() > 100000);
    check_chunk(prior, r, c);
  }
}

TEST_CASE("procedural prior: options switch structures off") {
  const scene::Scene& s = demo();
  world::ProceduralOptions o;
  o.buildings = o.trees = o.street_furniture = false;
  const world::ProceduralPrior prior(s, o);
  const world::ChunkPlan plan = world::plan_trajectory(s);
  const ChunkRequest r = request(s, plan, junction_chunk(plan));
  const ChunkVoxels c = prior.generate(r);
  check_chunk(prior, r, c);
  size_t structures = 0;
  for (const auto& v : c.voxels) {
    const auto k = static_cast<SemanticClass>(v.class_id);
    structures += k != SemanticClass::Road && k != SemanticClass::LaneMarker && k != SemanticClass::Curb &&
                  k != SemanticClass::Sidewalk && k != SemanticClass::Walkable && k != SemanticClass::OtherGround;
  }
  CHECK(structures == 0);
  // ground only: about two voxels per column of the 256 x 256 footprint
  CHECK(c.voxels.size() > 120000);
  CHECK(c.voxels.size() < 140000);
}

TEST_CASE("procedural prior: a map without lanes, degenerate polylines, bad requests") {
  scene::Scene s = demo();
  const world::ChunkPlan plan = world::plan_trajectory(s);
  s.map = scene::Map{};
  {
    const world::ProceduralPrior prior(s);
    CHECK(prior.road_surface().empty());
    const ChunkRequest r = request(s, plan, 0);
    const ChunkVoxels c = prior.generate(r);
    check_chunk(prior, r, c);
    std::array<uint64_t, world::kNumSemanticClasses> h{};
    for (const auto& v : c.voxels) ++h[v.class_id];
    CHECK(h[static_cast<size_t>(SemanticClass::OtherGround)] > 50000);
    CHECK(h[static_cast<size_t>(SemanticClass::Road)] == 0);
    // the ego path stays clear of buildings and trees
    size_t on_path = 0;
    for (const auto& v : c.voxels)
      if (v.class_id == static_cast<uint8_t>(SemanticClass::Building) ||
          v.class_id == static_cast<uint8_t>(SemanticClass::TreeTrunk)) {
        const glm::dvec3 p = centre_of(r, v.ijk);
        for (const auto& e : s.ego)
          if (e.valid && glm::length(glm::dvec2(p) - glm::dvec2(e.ego_to_world[3])) < 2.0) {
            ++on_path;
            break;
          }
      }
    CHECK(on_path == 0);
    MESSAGE("no-lane map chunk 0: " << histogram_text(h));
  }
  // degenerate polylines next to the real map
  s = demo();
  scene::RoadLine one;
  one.id = 9001, one.points = {{0.0, 0.0, 0.0}};
  scene::RoadLine rep;
  rep.id = 9002, rep.type = scene::RoadLineType::BrokenSingleWhite, rep.points = {{1.0, 1.0, 0.0}, {1.0, 1.0, 0.0}};
  s.map.road_lines.push_back(one), s.map.road_lines.push_back(rep);
  scene::RoadEdge edge;
  edge.id = 9003, edge.points = {{-30.0, 30.0, 0.0}, {-30.0, 30.0, 0.0}, {-30.0, 30.0, 0.0}};
  s.map.road_edges.push_back(edge);
  scene::Polygon cw;
  cw.id = 9004, cw.points = {{2.0, 2.0, 0.0}, {2.0, 2.0, 0.0}};
  s.map.crosswalks.push_back(cw);
  scene::Lane lane;
  lane.id = 9005, lane.points = {{40.0, 40.0, 0.0}};
  lane.interpolating = true;
  s.map.lanes.push_back(lane);
  {
    const world::ProceduralPrior prior(s);
    const ChunkRequest r = request(s, plan, 1);
    const ChunkVoxels c = prior.generate(r);
    CHECK(c.voxels.size() > 100000);
    check_chunk(prior, r, c);
    ChunkRequest bad = r;
    bad.chunk = plan.chunks.size();
    CHECK_THROWS_AS(prior.generate(bad), std::invalid_argument);
    bad = r;
    bad.plan = nullptr;
    CHECK_THROWS_AS(prior.generate(bad), std::invalid_argument);
  }
  world::ProceduralOptions o;
  o.sidewalk_width_min = 5.0, o.sidewalk_width_max = 1.0;
  CHECK_THROWS_AS(world::ProceduralPrior(s, o), std::invalid_argument);
}

TEST_CASE("procedural prior: a chunk of the real Waymo scenario") {
  const std::string data = test::test_data_dir();
  if (data.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  const std::string path = data + "/maps/waymo/motion_data_one_scenario.tfrecord";
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    MESSAGE("skipped: " << path << " not found");
    return;
  }
  std::fclose(f);
  const scene::Scene s = scene::load_scene(path);
  auto t0 = std::chrono::steady_clock::now();
  const world::ProceduralPrior prior(s);
  const double setup_s = seconds_since(t0);
  const world::ChunkPlan plan = world::plan_trajectory(s);
  REQUIRE(!plan.chunks.empty());
  const ChunkRequest r = request(s, plan, 0);
  t0 = std::chrono::steady_clock::now();
  const ChunkVoxels c = prior.generate(r);
  const double dt = seconds_since(t0);
  check_chunk(prior, r, c);
  std::array<uint64_t, world::kNumSemanticClasses> h{};
  for (const auto& v : c.voxels) ++h[v.class_id];
  CHECK(h[static_cast<size_t>(SemanticClass::Road)] > 10000);
  // the key camera is ~1.5 m above the road: the road lies 6.4 + 1.5 m below the chunk centre
  double road_z = 0.0;
  size_t n = 0;
  for (const auto& v : c.voxels)
    if (v.class_id == static_cast<uint8_t>(SemanticClass::Road)) road_z += centre_of(r, v.ijk).z, ++n;
  const double dz = road_z / double(n) - world::chunk_centre(plan.chunks[0]).z;
  CHECK(dz < -4.0);
  CHECK(dz > -12.0);
  // blocks mode over the real map: neighbouring blocks (same lattice row, 12.8 m overlap) agree
  const world::ChunkPlan blocks = world::plan_blocks(s);
  size_t pairs = 0;
  for (size_t k = 0; k + 1 < blocks.chunks.size() && pairs < 2; ++k)
    if (blocks.info[k].lattice_i == blocks.info[k + 1].lattice_i &&
        blocks.info[k].lattice_j + 1 == blocks.info[k + 1].lattice_j) {
      check_overlap(prior, s, blocks, k, k + 1);
      check_chunk(prior, request(s, blocks, k), prior.generate(request(s, blocks, k)));
      ++pairs;
    }
  CHECK(pairs > 0);
  char buf[160];
  std::snprintf(buf, sizeof buf, "waymo: setup %.0f ms, chunk 0 %.0f ms, road %.1f m below the chunk centre; ",
                1e3 * setup_s, 1e3 * dt, -dz);
  MESSAGE(buf << histogram_text(h));
}
