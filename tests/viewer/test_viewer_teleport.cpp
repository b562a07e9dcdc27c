// viewer/teleport.h: teleport targets from a hand-built scene's map and a
// hand-built world's chunks, and placing the car on the ground there facing
// along the lane; viewer/script.h's teleport / shadows / ao / load / frame-shot(s) commands.
#include <doctest/doctest.h>

#include "script.h"
#include "teleport.h"

#include <cmath>
#include <stdexcept>

using namespace icube;

namespace {

constexpr double kHalfPi = 1.57079632679489661923;

// Road floor (top at z = 0) over x in [0, 15) m, a building (roof at 5 m) over x in [15, 20) m,
// y in [-5, 45) m.
world::VoxelGrid town() {
  world::VoxelGrid g;
  for (int x = 0; x < 100; ++x)
    for (int y = -25; y < 225; ++y) {
      if (x < 75) {
        g.set({x, y, -1}, 18);
      } else {
        for (int z = -1; z < 25; ++z) g.set({x, y, z}, 14);
      }
    }
  return g;
}

scene::Scene town_scene() {
  scene::Scene s;
  scene::Lane l;
  l.id = 7;
  l.type = scene::LaneType::SurfaceStreet;
  l.points = {{10, 0, 0}, {10, 20, 0}, {10, 40, 0}};
  s.map.lanes.push_back(l);
  scene::Polygon cw;
  cw.id = 3;
  cw.points = {{8, 24, 0}, {12, 24, 0}, {12, 27, 0}, {8, 27, 0}};
  s.map.crosswalks.push_back(cw);
  scene::StopSign st;
  st.id = 5;
  st.position = {13, 30, 0};
  st.lanes = {7};
  s.map.stop_signs.push_back(st);
  scene::EgoPose e;
  e.ego_to_world = glm::dmat4(glm::dvec4(0, 1, 0, 0), glm::dvec4(-1, 0, 0, 0), glm::dvec4(0, 0, 1, 0),
                              glm::dvec4(10, 2, 0, 1));  // facing +y at (10, 2)
  s.ego.push_back(e);
  return s;
}

}  // namespace

TEST_CASE("viewer teleport: map targets, their headings and placing the car on the ground") {
  const scene::Scene s = town_scene();
  const world::VoxelGrid g = town();
  const std::vector<viewer::TeleportTarget> t = viewer::map_targets(s);
  REQUIRE(t.size() == 4);
  CHECK(t[0].kind == viewer::TargetKind::EgoStart);
  CHECK(t[1].kind == viewer::TargetKind::Lane);
  CHECK(t[1].label == "lane 7 (surface_street)");
  CHECK(t[1].position.y == doctest::Approx(20.0));
  CHECK(t[2].kind == viewer::TargetKind::Crosswalk);
  CHECK(t[3].kind == viewer::TargetKind::StopSign);
  for (const viewer::TeleportTarget& x : t) {
    REQUIRE(x.yaw.has_value());
    CHECK(*x.yaw == doctest::Approx(kHalfPi));
  }
  viewer::VehicleLimits lim;
  viewer::GroundOptions ground;
  for (const viewer::TeleportTarget& x : t) {
    viewer::VehicleState car;
    car.position = {50, 50, 30};
    car.speed = 7.0;
    car.yaw = 1.0;
    REQUIRE(viewer::place_at_target(car, x, g, lim, ground, &s));
    CHECK(car.position.z == doctest::Approx(0.0));
    CHECK(car.position.x == doctest::Approx(x.position.x));
    CHECK(car.yaw == doctest::Approx(kHalfPi));
    CHECK(car.speed == 0.0);
  }
  // A point with no ground below: the car stays where it was.
  viewer::TeleportTarget nowhere{viewer::TargetKind::Lane, "nowhere", {200, 200, 0}, 0.0};
  viewer::VehicleState car;
  car.position = {1, 2, 3};
  CHECK_FALSE(viewer::place_at_target(car, nowhere, g, lim, ground, &s));
  CHECK(car.position == glm::dvec3(1, 2, 3));
  CHECK_FALSE(viewer::nearest_lane_heading(s, {40, 20}, 10.0).has_value());
  CHECK(*viewer::nearest_lane_heading(s, {13, 5}, 10.0) == doctest::Approx(kHalfPi));
}

TEST_CASE("viewer teleport: chunks are the 51.2 m tiles with ground; the car lands on road, not on a roof") {
  const world::VoxelGrid g = town();
  const std::vector<viewer::TeleportTarget> c = viewer::chunk_targets(g);
  REQUIRE(c.size() == 2);
  CHECK(c[0].label == "chunk (0, -1)");
  CHECK(c[1].label == "chunk (0, 0)");
  CHECK(c[1].position.x == doctest::Approx(25.6));
  viewer::VehicleLimits lim;
  viewer::GroundOptions ground;
  viewer::VehicleState car;
  car.yaw = 0.3;
  // The tile centre (25.6, 25.6) has no ground; the nearest road column is at x < 15 (the building is passed over).
  REQUIRE(viewer::place_at_target(car, c[1], g, lim, ground, nullptr));
  CHECK(car.position.z == doctest::Approx(0.0));
  CHECK(car.position.x < 15.0);
  CHECK(car.position.x > 13.0);
  CHECK(car.yaw == doctest::Approx(0.3));  // no scene: the heading is kept
  const scene::Scene s = town_scene();
  REQUIRE(viewer::place_at_target(car, c[1], g, lim, ground, &s));
  CHECK(car.yaw == doctest::Approx(kHalfPi));  // the lane at x = 10 is within 12 m
}

TEST_CASE("viewer script: teleport, shadows, ao, load and frame-shot commands") {
  const auto ev = viewer::parse_script(
      "0 teleport feature 3\n0 teleport lane 7 (surface_street)\n0 shadows on\n0 ao 4\n0 ao off\n0 load\n"
      "0 frame-shot a.png 1 40\n",
      "s");
  REQUIRE(ev.size() == 7);
  CHECK(ev[1].args.size() == 3);
  CHECK(ev[6].args[2] == "40");
  CHECK_THROWS_AS(viewer::parse_script("0 ao 99\n", "s"), std::invalid_argument);
  CHECK_THROWS_AS(viewer::parse_script("0 shadows maybe\n", "s"), std::invalid_argument);
  CHECK_THROWS_AS(viewer::parse_script("0 frame-shot a.png x 1\n", "s"), std::invalid_argument);
  CHECK_THROWS_AS(viewer::parse_script("0 frame-shot a.png 1\n", "s"), std::invalid_argument);
  const auto shots = viewer::parse_script("0 frame-shots out/frame 10\n", "s");
  REQUIRE(shots.size() == 1);
  CHECK(shots[0].command == "frame-shots");
  CHECK(shots[0].args[1] == "10");
  CHECK_THROWS_AS(viewer::parse_script("0 frame-shots out/frame 0\n", "s"), std::invalid_argument);
  CHECK_THROWS_AS(viewer::parse_script("0 frame-shots out/frame\n", "s"), std::invalid_argument);
}
