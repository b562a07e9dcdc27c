// Chunk planning (engine/world/chunk_plan.h): trajectory keys every 38.4 m
// along a synthetic L-shaped drive, straight extrapolation, the chunk frame
// 6.4 m above the key camera, orthonormal FLU axes, parked and too-short
// drives, blocks mode on a hand-computed synthetic map (road-surface points
// decide which blocks hold road), determinism, a 100 km
// shift, the JSON and the plot, and the real Waymo scenario when
// ../shared/data is present.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "scene/frames.h"
#include "scene/input_error.h"
#include "scene/scene_load.h"
#include "world/chunk_plan.h"
#include "world/chunk_plan_plot.h"
#include "world/road_surface.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <utility>

using namespace icube;
using world::ChunkKind;
using world::ChunkPlan;

namespace {

constexpr double kPi = std::numbers::pi;

glm::dmat4 pose_at(glm::dvec3 p, double yaw) {
  glm::dmat4 m(1.0);
  m[0] = {std::cos(yaw), std::sin(yaw), 0.0, 0.0};
  m[1] = {-std::sin(yaw), std::cos(yaw), 0.0, 0.0};
  m[3] = glm::dvec4(p, 1.0);
  return m;
}

// East 100 m from `o`, then north 100 m; samples every 0.7 m plus the corner
// and the end, so the polyline is exactly the L.
scene::Scene l_drive(glm::dvec3 o = glm::dvec3(0.0), bool camera = true) {
  scene::Scene s;
  s.provenance.source_file = "l_drive.json";
  std::vector<double> arcs;
  for (int i = 0; i * 0.7 < 200.0; ++i) arcs.push_back(i * 0.7);
  arcs.push_back(200.0);
  arcs.insert(std::upper_bound(arcs.begin(), arcs.end(), 100.0), 100.0);
  for (double a : arcs) {
    scene::EgoPose e;
    e.ego_to_world = a <= 100.0 ? pose_at(o + glm::dvec3(a, 0, 0), a < 100.0 ? 0.0 : kPi / 2)
                                : pose_at(o + glm::dvec3(100.0, a - 100.0, 0.0), kPi / 2);
    s.ego.push_back(e);
    s.timestamps.push_back(static_cast<double>(s.timestamps.size()) * 0.1);
  }
  if (camera) s.cameras.push_back(scene::waymo_front_camera());
  return s;
}

// Arc length along the L of a point on it (and its distance from the L).
std::pair<double, double> l_arc(glm::dvec3 p, glm::dvec3 o = glm::dvec3(0.0)) {
  const glm::dvec3 q = p - o;
  if (std::abs(q.y) <= 1e-9 && q.x <= 100.0) return {q.x, std::abs(q.y) + std::abs(q.z)};
  return {100.0 + q.y, std::abs(q.x - 100.0) + std::abs(q.z)};
}

void check_frame(const world::ChunkPose& c) {
  const glm::dvec3 x(c.chunk_to_world[0]), y(c.chunk_to_world[1]), z(c.chunk_to_world[2]);
  CHECK(glm::length(x) == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(glm::length(y) == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(glm::length(z) == doctest::Approx(1.0).epsilon(1e-12));
  CHECK(std::abs(glm::dot(x, y)) < 1e-12);
  CHECK(std::abs(glm::dot(x, z)) < 1e-12);
  CHECK(std::abs(glm::dot(y, z)) < 1e-12);
  CHECK(glm::dot(glm::cross(x, y), z) == doctest::Approx(1.0).epsilon(1e-12));  // right-handed
  CHECK(c.chunk_to_world[0][3] == 0.0);
  CHECK(c.chunk_to_world[3][3] == 1.0);
  // The origin is 6.4 m above the key camera along the camera's (= chunk's) up axis.
  CHECK(glm::length(world::chunk_centre(c) - (c.key_camera_world + 6.4 * z)) < 1e-9);
}

scene::Lane lane_pts(int64_t id, std::vector<glm::dvec3> pts) {
  scene::Lane l;
  l.id = id;
  l.points = std::move(pts);
  return l;
}

// Hand-made map (see the test below for the expected blocks).
scene::Scene block_map(glm::dvec3 o = glm::dvec3(0.0)) {
  scene::Scene s;
  s.provenance.source_file = "blocks.json";
  auto P = [&](double x, double y, double z) { return o + glm::dvec3(x, y, z); };
  s.map.road_edges.push_back({1, scene::RoadEdgeType::Boundary, {P(0, 0, 0), P(10, 0, 0)}});
  s.map.road_edges.push_back({2, scene::RoadEdgeType::Boundary, {P(100, 10, 0)}});
  s.map.road_edges.push_back({3, scene::RoadEdgeType::Curb, {P(200, 200, 0)}});  // edge only
  s.map.lanes.push_back(lane_pts(10, {P(5, 5, 1), P(100, 12, 2)}));
  s.map.lanes.push_back(lane_pts(11, {P(300, 3, 0)}));  // lane only
  scene::RoadLine line;
  line.id = 20;
  line.points = {P(100, 40, 4)};  // in blocks (2,0) and (2,1): z only
  s.map.road_lines.push_back(line);
  return s;
}

}  // namespace

TEST_CASE("chunk plan: trajectory keys every 38.4 m along an L-shaped drive") {
  const scene::Scene s = l_drive();
  const ChunkPlan plan = world::plan_trajectory(s);
  CHECK(plan.mode == world::PlanMode::Trajectory);
  CHECK(plan.path_length_m == doctest::Approx(200.0).epsilon(1e-12));
  CHECK_FALSE(plan.parked);
  // Keys at 0, 38.4, ..., 192 (6 on the path) + 1 extrapolated at 230.4.
  REQUIRE(plan.chunks.size() == 7);
  REQUIRE(plan.info.size() == 7);
  const scene::Camera cam = s.cameras[0];
  for (size_t k = 0; k < plan.chunks.size(); ++k) {
    CAPTURE(k);
    const world::ChunkPose& c = plan.chunks[k];
    const world::ChunkInfo& info = plan.info[k];
    CHECK(c.index == static_cast<int32_t>(k));
    CHECK(info.kind == (k < 6 ? ChunkKind::Key : ChunkKind::Extrapolated));
    const double want = static_cast<double>(k) * world::kChunkStride;
    CHECK(std::abs(info.arc_length_m - want) <= 1e-9);
    check_frame(c);
    if (k < 6) {
      const auto [arc, off] = l_arc(info.ego_position);
      CHECK(std::abs(arc - want) <= 1e-9);
      CHECK(off <= 1e-9);
    }
    // Key camera = key ego pose · camera mount; heading along the leg.
    const double yaw = info.ego_position.x < 100.0 - 1e-9 ? 0.0 : kPi / 2;
    CHECK(std::abs(world::chunk_heading(c) - yaw) < 1e-12);
    const glm::dvec3 want_cam = glm::dvec3(pose_at(info.ego_position, yaw) * cam.camera_to_ego[3]);
    CHECK(glm::length(c.key_camera_world - want_cam) < 1e-9);
  }
  CHECK(plan.chunks[0].key_camera_world == glm::dvec3(1.5, 0.0, 2.0));
  CHECK(plan.info[0].time_index == 0);
  // Spacing between consecutive keys, measured along the L.
  for (size_t k = 1; k < 6; ++k)
    CHECK(std::abs(l_arc(plan.info[k].ego_position).first - l_arc(plan.info[k - 1].ego_position).first -
                   world::kChunkStride) <= 1e-9);
}

TEST_CASE("chunk plan: extrapolation continues straight along the last heading") {
  world::PlanOptions o;
  o.extrapolate_chunks = 3;
  const ChunkPlan plan = world::plan_trajectory(l_drive(), o);
  REQUIRE(plan.chunks.size() == 9);
  for (size_t k = 6; k < 9; ++k) {
    CAPTURE(k);
    CHECK(plan.info[k].kind == ChunkKind::Extrapolated);
    CHECK(plan.info[k].time_index == -1);
    const double beyond = static_cast<double>(k) * world::kChunkStride - 200.0;
    CHECK(glm::length(plan.info[k].ego_position - glm::dvec3(100.0, 100.0 + beyond, 0.0)) < 1e-9);
    CHECK(glm::length(glm::dvec3(plan.chunks[k].chunk_to_world[0]) - glm::dvec3(0, 1, 0)) < 1e-12);
    check_frame(plan.chunks[k]);
  }
  o.extrapolate_chunks = 0;
  CHECK(world::plan_trajectory(l_drive(), o).chunks.size() == 6);
}

TEST_CASE("chunk plan: max_chunks keeps the plan's first chunks, in order, and says so") {
  world::PlanOptions o;
  const ChunkPlan all = world::plan_chunks(l_drive(), world::PlanMode::Trajectory, o);
  REQUIRE(all.chunks.size() == 7);
  o.max_chunks = 2;
  const ChunkPlan first = world::plan_chunks(l_drive(), world::PlanMode::Trajectory, o);
  REQUIRE(first.chunks.size() == 2);
  REQUIRE(first.info.size() == 2);
  for (size_t k = 0; k < 2; ++k) {
    CHECK(first.chunks[k].chunk_to_world == all.chunks[k].chunk_to_world);
    CHECK(first.info[k].ego_position == all.info[k].ego_position);
  }
  REQUIRE(!first.notes.empty());
  CHECK(first.notes.back() == "only the first 2 of 7 chunks are planned (--max-chunks)");
  o.max_chunks = 7;  // no fewer than planned: unchanged, no note
  CHECK(world::plan_chunks(l_drive(), world::PlanMode::Trajectory, o).notes.size() == all.notes.size());
  o.max_chunks = -1;
  CHECK_THROWS_AS(world::plan_chunks(l_drive(), world::PlanMode::Trajectory, o), std::invalid_argument);
}

TEST_CASE("chunk plan: a tilted camera keeps orthonormal axes; no camera = ego raised 1.5 m") {
  scene::Scene s = l_drive();
  // Camera pitched down 7°, yawed 3°, rolled 1°; ego yaw changes at the corner (slerp there).
  scene::BoxState r;
  r.heading = 3.0 * kPi / 180, r.pitch = 7.0 * kPi / 180, r.roll = 1.0 * kPi / 180;
  glm::dmat4 c2e(scene::box_rotation(r));
  c2e[3] = glm::dvec4(1.2, 0.1, 1.7, 1.0);
  s.cameras[0].camera_to_ego = c2e;
  // Keys that fall between a 0° and a 90° pose: make the corner samples turn gradually.
  for (scene::EgoPose& e : s.ego) {
    const glm::dvec3 p(e.ego_to_world[3]);
    if (p.x > 95.0 && p.y < 5.0) e.ego_to_world = pose_at(p, kPi / 4);
  }
  world::PlanOptions o;
  o.stride_m = 9.7;
  const ChunkPlan plan = world::plan_trajectory(s, o);
  REQUIRE(plan.chunks.size() == 22);  // keys at 0, 9.7, ..., 194 + 1
  for (const world::ChunkPose& c : plan.chunks) check_frame(c);

  const scene::Scene bare = l_drive(glm::dvec3(0.0), false);
  const ChunkPlan p2 = world::plan_trajectory(bare);
  REQUIRE(p2.chunks.size() == 7);
  for (size_t k = 0; k < p2.chunks.size(); ++k) {
    CHECK(p2.chunks[k].key_camera_world == p2.info[k].ego_position + glm::dvec3(0, 0, 1.5));
    CHECK(world::chunk_centre(p2.chunks[k]).z == doctest::Approx(1.5 + 6.4).epsilon(1e-12));
  }
}

TEST_CASE("chunk plan: too few poses is an error; a parked ego gives one chunk") {
  scene::Scene s = l_drive();
  s.ego.resize(1);
  CHECK_THROWS_WITH_AS(world::plan_trajectory(s),
                       doctest::Contains("trajectory mode needs an ego trajectory with at least 2 valid poses"),
                       scene::InputError);
  s = l_drive();
  for (size_t i = 1; i < s.ego.size(); ++i) s.ego[i].valid = false;
  CHECK_THROWS_AS(world::plan_trajectory(s), scene::InputError);
  s.ego.clear();
  CHECK_THROWS_AS(world::plan_trajectory(s), scene::InputError);

  scene::Scene parked = l_drive();
  const scene::EgoPose still = parked.ego[3];
  parked.ego.assign(50, still);
  parked.timestamps.resize(50);
  parked.ego[7].ego_to_world[3].x += 0.01;  // jitter below the parked threshold
  const ChunkPlan plan = world::plan_trajectory(parked);
  CHECK(plan.parked);
  REQUIRE(plan.chunks.size() == 1);
  CHECK(plan.info[0].kind == ChunkKind::Key);
  CHECK(glm::length(plan.chunks[0].key_camera_world - glm::dvec3(2.1 + 1.5, 0.0, 2.0)) < 1e-12);
  REQUIRE(plan.notes.size() == 1);

  world::PlanOptions bad;
  bad.stride_m = 0.0;
  CHECK_THROWS_AS(world::plan_trajectory(l_drive(), bad), std::invalid_argument);
}

TEST_CASE("chunk plan: blocks mode keeps exactly the road blocks of a synthetic map") {
  const ChunkPlan plan = world::plan_blocks(block_map());
  CHECK(plan.mode == world::PlanMode::Blocks);
  CHECK(plan.lattice_anchor == glm::dvec2(0.0, 0.0));
  // Hand-computed: (0,0) holds edges (0,0),(10,0) and lane (5,5); (2,0) holds
  // edge (100,10) and lane (100,12). (4..5, 4..5) have only the edge at
  // (200,200), (7,0) only the lane at (300,3), (2,1) only the road line.
  REQUIRE(plan.chunks.size() == 2);
  CHECK(plan.info[0].lattice_i == 0);
  CHECK(plan.info[0].lattice_j == 0);
  CHECK(plan.info[1].lattice_i == 2);
  CHECK(plan.info[1].lattice_j == 0);
  CHECK(plan.info[0].edge_points == 2);
  // Road-surface points (RoadSurface::points()) in each kept footprint, counted here independently.
  const world::RoadSurface surface = world::build_road_surface(block_map().map);
  for (size_t k = 0; k < plan.chunks.size(); ++k) {
    const glm::dvec3 c = world::chunk_centre(plan.chunks[k]);
    size_t in_footprint = 0;
    for (const glm::dvec3& p : surface.points())
      in_footprint += p.x >= c.x - 25.6 && p.x < c.x + 25.6 && p.y >= c.y - 25.6 && p.y < c.y + 25.6;
    CAPTURE(k);
    CHECK(plan.info[k].surface_points == in_footprint);
    CHECK(in_footprint > 100);  // a filled surface, not one lane vertex
  }
  const glm::dvec3 c0 = world::chunk_centre(plan.chunks[0]), c1 = world::chunk_centre(plan.chunks[1]);
  CHECK(c0 == glm::dvec3(25.6, 25.6, 0.0 + 1.5 + 6.4));          // median z of {0, 0, 1} = 0
  CHECK(glm::length(c1 - glm::dvec3(2 * 38.4 + 25.6, 25.6, 2.0 + 1.5 + 6.4)) < 1e-12);  // median {0, 2, 4}
  for (const world::ChunkPose& c : plan.chunks) {
    CHECK(glm::dmat3(c.chunk_to_world) == glm::dmat3(1.0));  // translation only
    check_frame(c);
  }
  CHECK(plan.notes.size() == 1);  // 6 blocks dropped

  // A precomputed surface gives the same plan; an empty one keeps no block.
  CHECK(world::plan_to_json(world::plan_blocks(block_map(), surface)) == world::plan_to_json(plan));
  const ChunkPlan none = world::plan_blocks(block_map(), world::RoadSurface());
  CHECK(none.chunks.empty());
  CHECK(none.notes.size() == 1);

  scene::Scene no_lanes = block_map();
  no_lanes.map.lanes.clear();
  CHECK_THROWS_WITH_AS(world::plan_blocks(no_lanes), doctest::Contains("blocks mode needs road edges and lane"),
                       scene::InputError);
}

TEST_CASE("chunk plan: deterministic, and a 100 km shift gives the same plan shifted") {
  const glm::dvec3 shift(1.0e5, -1.0e5, 37.0);
  CHECK(world::plan_to_json(world::plan_blocks(block_map())) == world::plan_to_json(world::plan_blocks(block_map())));
  CHECK(world::plan_to_json(world::plan_trajectory(l_drive())) == world::plan_to_json(world::plan_trajectory(l_drive())));
  for (const bool blocks : {false, true}) {
    CAPTURE(blocks);
    const ChunkPlan a = blocks ? world::plan_blocks(block_map()) : world::plan_trajectory(l_drive());
    const ChunkPlan b = blocks ? world::plan_blocks(block_map(shift)) : world::plan_trajectory(l_drive(shift));
    REQUIRE(a.chunks.size() == b.chunks.size());
    for (size_t k = 0; k < a.chunks.size(); ++k) {
      CHECK(glm::length(world::chunk_centre(b.chunks[k]) - world::chunk_centre(a.chunks[k]) - shift) < 1e-6);
      CHECK(glm::length(b.chunks[k].key_camera_world - a.chunks[k].key_camera_world - shift) < 1e-6);
      for (int col = 0; col < 3; ++col)
        CHECK(glm::length(glm::dvec3(b.chunks[k].chunk_to_world[col]) - glm::dvec3(a.chunks[k].chunk_to_world[col])) <
              1e-12);
      CHECK(a.info[k].lattice_i == b.info[k].lattice_i);
      CHECK(a.info[k].lattice_j == b.info[k].lattice_j);
    }
  }
}

TEST_CASE("chunk plan: JSON and plot") {
  const scene::Scene s = l_drive();
  const ChunkPlan plan = world::plan_trajectory(s);
  const nlohmann::json j = nlohmann::json::parse(world::plan_to_json(plan));
  CHECK(j["format"] == "icube-chunk-plan");
  CHECK(j["mode"] == "trajectory");
  REQUIRE(j["chunks"].size() == plan.chunks.size());
  CHECK(j["chunks"][6]["kind"] == "extrapolated");
  CHECK(j["chunks"][3]["chunk_to_world"][0][3].get<double>() == plan.chunks[3].chunk_to_world[3].x);
  CHECK(j["chunks"][3]["chunk_to_world"][2][3].get<double>() == plan.chunks[3].chunk_to_world[3].z);

  const std::vector<glm::dvec2> fp = world::chunk_footprint(plan.chunks[0]);
  REQUIRE(fp.size() == 4);
  CHECK(glm::length(fp[1] - glm::dvec2(1.5 + 25.6, 25.6)) < 1e-12);  // front-left corner

  const scene::MapPlot p = world::render_plan(s, plan);
  // The window holds every footprint: the extrapolated chunk's far edge reaches y = 100 + 30.4 + 1.5 + 25.6.
  const glm::dvec2 top = p.view.to_pixel(100.0, 100.0 + 30.4 + 1.5 + 25.6);
  CHECK(top.y > p.view.map_y0);
  // Chunk 2's outline (its rear edge, x = 76.8 + 1.5 - 25.6, at y = -15) is drawn in its colour.
  const glm::dvec2 edge = p.view.to_pixel(76.8 + 1.5 - 25.6, -15.0);
  const scene::Rgba got = p.image.pixel(static_cast<int>(edge.x), static_cast<int>(edge.y));
  const scene::Rgba want = world::chunk_colour(2);
  CAPTURE(int(got.r));
  CAPTURE(int(got.g));
  CAPTURE(int(got.b));
  CHECK(std::abs(int(got.r) - int(want.r)) + std::abs(int(got.g) - int(want.g)) + std::abs(int(got.b) - int(want.b)) <
        120);
}

TEST_CASE("chunk plan: the real Waymo scenario") {
  const std::string data = icube::test::test_data_dir();
  if (data.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  const scene::Scene s = scene::load_scene(data + "/maps/waymo/motion_data_one_scenario.tfrecord");
  const ChunkPlan blocks = world::plan_blocks(s);
  CHECK(blocks.chunks.size() >= 10);
  std::set<std::pair<int, int>> seen;
  for (size_t k = 0; k < blocks.chunks.size(); ++k) {
    CHECK(blocks.info[k].edge_points > 0);
    CHECK(blocks.info[k].surface_points > 0);
    CHECK(seen.insert({blocks.info[k].lattice_i, blocks.info[k].lattice_j}).second);
    const double z = world::chunk_centre(blocks.chunks[k]).z;
    CHECK(z > -186.9 + 7.9 - 1e-9);  // map z in [-186.9, -183.0]
    CHECK(z < -183.0 + 7.9 + 1e-9);
  }
  // The ego is parked in this scenario: one chunk.
  const ChunkPlan traj = world::plan_trajectory(s);
  CHECK(traj.parked);
  CHECK(traj.chunks.size() == 1);
}
