// The viewer's CPU logic (viewer/, library icube_viewer_core): the kinematic
// bicycle model and ground following, the 10 Hz recorder, interpolation to N
// frames, trajectory files read back by engine/render/buffers/trajectory.h,
// the script parser, frame-time percentiles, and a whole recorded drive on the
// demo town built with the procedural prior (shape, progress, heights).
#include <doctest/doctest.h>

#include "recorder.h"
#include "script.h"
#include "vehicle.h"

#include "render/buffers/trajectory.h"
#include "scene/frames.h"
#include "world/demo_scene.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <filesystem>
#include <stdexcept>

using namespace icube;
using namespace icube::viewer;

namespace {

constexpr uint8_t kRoad = 18, kCurb = 17, kBuilding = 14, kVegetation = 15, kCar = 1;

// A flat road (top at z = 0) over x in [-10, 60), y in [-10, 10); a 0.2 m curb
// step for x >= 20, a 3 m building wall at x in [40, 42).
world::VoxelGrid hand_made_world() {
  world::VoxelGrid g(glm::dvec3(0.0), 0.2);
  for (int i = -50; i < 300; ++i)
    for (int j = -50; j < 50; ++j) {
      g.set({i, j, -1}, kRoad);
      if (i >= 100) g.set({i, j, 0}, kCurb);  // top at 0.2 m
      if (i >= 200 && i < 210)
        for (int k = 1; k < 15; ++k) g.set({i, j, k}, kBuilding);
    }
  g.set({10, 0, 2}, kCar);        // a car voxel is not ground
  g.set({12, 0, 10}, kVegetation);  // a canopy 2 m up: above the step height, ignored
  return g;
}

glm::dmat4 pose_at(double x, double y, double yaw) {
  VehicleState s;
  s.position = {x, y, 0.0};
  s.yaw = yaw;
  return dash_camera_c2w(s, scene::waymo_front_camera());
}

}  // namespace

TEST_CASE("viewer: bicycle model limits, turning radius, reverse") {
  VehicleLimits lim;
  GroundOptions ground;
  ground.follow = false;
  SUBCASE("full throttle accelerates monotonically up to max_speed") {
    VehicleState s;
    double prev = 0.0;
    for (int i = 0; i < 30 * 60; ++i) {
      step_vehicle(s, {1.0, 0.0, 0.0}, 1.0 / 30, lim, nullptr, ground);
      CHECK(s.speed >= prev - 1e-12);
      prev = s.speed;
    }
    CHECK(s.speed <= lim.max_speed + 1e-9);
    CHECK(s.speed > 0.95 * lim.max_speed);
    CHECK(std::fabs(s.position.y) < 1e-9);
    CHECK(s.position.x == doctest::Approx(s.odometer).epsilon(1e-9));
  }
  SUBCASE("braking stops the car and does not reverse it") {
    VehicleState s;
    s.speed = 20.0;
    int frames = 0;
    while (s.speed > 0.0 && frames < 300) {
      step_vehicle(s, {0.0, 0.4, 0.0}, 1.0 / 30, lim, nullptr, ground);
      ++frames;
    }
    CHECK(s.speed == 0.0);
    CHECK(!s.reversing);
    CHECK(frames == doctest::Approx(20.0 / (0.4 * lim.max_brake + lim.rolling) * 30).epsilon(0.1));
  }
  SUBCASE("steady turn: radius L / tan(steer), steer rate and limit respected") {
    VehicleState s;
    s.speed = 3.0;
    double prev_steer = 0.0;
    for (int i = 0; i < 30 * 20; ++i) {
      step_vehicle(s, {0.05, 0.0, 1.0}, 1.0 / 30, lim, nullptr, ground);
      CHECK(s.steer - prev_steer <= lim.steer_rate / 30 + 1e-12);
      CHECK(s.steer <= lim.max_steer + 1e-12);
      prev_steer = s.steer;
    }
    // Yaw rate = v tan(steer) / L.
    const double rate = s.speed * std::tan(s.steer) / lim.wheelbase;
    const double yaw0 = s.yaw;
    step_vehicle(s, {0.05, 0.0, 1.0}, 0.1, lim, nullptr, ground);
    CHECK(scene::wrap_angle(s.yaw - yaw0) == doctest::Approx(rate * 0.1).epsilon(0.02));
  }
  SUBCASE("at speed the steer angle is limited by the lateral acceleration") {
    VehicleState s;
    s.speed = 25.0;
    for (int i = 0; i < 60; ++i) step_vehicle(s, {0.3, 0.0, 1.0}, 1.0 / 30, lim, nullptr, ground);
    const double lateral = s.speed * s.speed * std::tan(s.steer) / lim.wheelbase;
    CHECK(lateral <= lim.max_lateral * 1.05);
  }
  SUBCASE("brake at a standstill engages reverse, throttle leaves it") {
    VehicleState s;
    for (int i = 0; i < 60; ++i) step_vehicle(s, {0.0, 1.0, 0.0}, 1.0 / 30, lim, nullptr, ground);
    CHECK(s.reversing);
    CHECK(s.speed < 0.0);
    CHECK(s.speed >= -lim.max_reverse);
    CHECK(s.position.x < 0.0);
    for (int i = 0; i < 90; ++i) step_vehicle(s, {1.0, 0.0, 0.0}, 1.0 / 30, lim, nullptr, ground);
    CHECK(!s.reversing);
    CHECK(s.speed > 0.0);
  }
}

TEST_CASE("viewer: ground following by the downward query, curbs, walls, zero height") {
  const world::VoxelGrid g = hand_made_world();
  CHECK(ground_height(g, 1.0, 0.1, 1.0).value() == doctest::Approx(0.0));
  CHECK(ground_height(g, 2.1, 0.1, 1.0).value() == doctest::Approx(0.0));   // through the car voxel
  CHECK(ground_height(g, 2.5, 0.1, 1.0).value() == doctest::Approx(0.0));   // canopy above the start
  CHECK(ground_height(g, 25.0, 0.1, 1.0).value() == doctest::Approx(0.2));  // curb
  CHECK(!ground_height(g, 100.0, 0.0, 1.0));                                // outside the world

  VehicleLimits lim;
  GroundOptions ground;
  VehicleState s;
  s.position = {0.0, 0.0, 5.0};
  REQUIRE(settle_vehicle(s, lim, g, ground, 10.0));
  CHECK(s.position.z == doctest::Approx(0.0));
  double max_x = 0.0;
  for (int i = 0; i < 30 * 20; ++i) {
    step_vehicle(s, {0.6, 0.0, 0.0}, 1.0 / 30, lim, &g, ground);
    if (s.position.x > 20.2) CHECK(s.position.z == doctest::Approx(0.2));  // up the curb
    max_x = std::max(max_x, s.position.x);
  }
  CHECK(max_x < 40.0);  // the wall stops it
  CHECK(max_x > 39.0);
  CHECK(s.speed == doctest::Approx(0.0).epsilon(0.5));

  GroundOptions zero;
  zero.zero_height = true;
  zero.zero_z = -3.0;
  VehicleState z;
  for (int i = 0; i < 60; ++i) step_vehicle(z, {1.0, 0.0, 0.0}, 1.0 / 30, lim, &g, zero);
  CHECK(z.position.z == -3.0);
  CHECK(z.pitch == 0.0);
}

TEST_CASE("viewer: cameras are OpenCV poses (dash = the scene camera on the car)") {
  VehicleState s;
  s.position = {10.0, 5.0, 1.0};
  s.yaw = 0.5;
  const scene::Camera cam = scene::waymo_front_camera();
  const glm::dmat4 c2w = dash_camera_c2w(s, cam);
  // OpenCV z (forward) = the car's heading, y (down) = -z world.
  CHECK(c2w[2][0] == doctest::Approx(std::cos(0.5)));
  CHECK(c2w[2][1] == doctest::Approx(std::sin(0.5)));
  CHECK(c2w[1][2] == doctest::Approx(-1.0));
  CHECK(c2w[3][2] == doctest::Approx(1.0 + scene::kWaymoFrontMount.z));
  CHECK(glm::determinant(glm::dmat3(c2w)) == doctest::Approx(1.0));
  const glm::dmat4 chase = chase_camera_c2w(s);
  CHECK(glm::dvec3(chase[3]).z > s.position.z + 2.0);
  CHECK(glm::determinant(glm::dmat3(chase)) == doctest::Approx(1.0));
  FlyCamera f;
  f.yaw = 1.0;
  f.pitch = -0.3;
  const glm::dmat4 fc = fly_camera_c2w(f);
  CHECK(glm::length(glm::dvec3(fc[2]) - fly_forward(f)) < 1e-12);
  const VehicleState back = vehicle_from_ego(vehicle_to_world(s));
  CHECK(back.yaw == doctest::Approx(0.5));
}

TEST_CASE("viewer: recorder samples at 10 Hz and closes passes") {
  Recorder r;
  r.add_keyframe(pose_at(0, 0, 0));
  CHECK(!r.end_pass());  // one pose is not a pass
  r.discard_current();
  r.start_continuous(0.0);
  for (int i = 0; i <= 90; ++i) r.update(i / 30.0, pose_at(i * 0.1, 0, 0));  // 3 s at 30 fps
  CHECK(r.current().size() == 31);
  // Uneven frame times keep the 10 Hz grid.
  r.update(3.5, pose_at(20, 0, 0));
  r.update(3.55, pose_at(21, 0, 0));
  CHECK(r.current().size() == 32);
  CHECK(r.end_pass());
  CHECK(!r.continuous());
  CHECK(r.passes().size() == 1);
  CHECK(r.current().empty());
}

TEST_CASE("viewer: interpolation to N frames (lerp + slerp, constant speed, through the keys)") {
  SUBCASE("two keys: ends exact, midpoint lerp and slerp") {
    const Pass keys = {pose_at(0, 0, 0), pose_at(10, 0, 1.0)};
    const Pass p = interpolate_pass(keys, kDefaultInterpolatedFrames);
    REQUIRE(p.size() == 93);
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) {
        CHECK(p.front()[c][r] == doctest::Approx(keys[0][c][r]));
        CHECK(p.back()[c][r] == doctest::Approx(keys[1][c][r]));
      }
    const glm::dmat4& mid = p[46];
    CHECK(glm::dvec3(mid[3]).x == doctest::Approx(0.5 * (keys[0][3].x + keys[1][3].x)));
    // The forward axis turned half way (yaw 0.5).
    CHECK(std::atan2(mid[2][1], mid[2][0]) == doctest::Approx(0.5));
    for (const glm::dmat4& m : p) CHECK(glm::determinant(glm::dmat3(m)) == doctest::Approx(1.0));
  }
  SUBCASE("uneven samples become evenly spaced frames; every key is passed through") {
    Pass keys;
    double x = 0.0;
    for (int i = 0; i < 20; ++i) {
      keys.push_back(pose_at(x, 0, 0));
      x += 0.1 + 0.2 * i;  // accelerating car
    }
    const Pass p = interpolate_pass(keys, 50);
    const double step = glm::dvec3(p[1][3]).x - glm::dvec3(p[0][3]).x;
    for (size_t i = 1; i < p.size(); ++i)
      CHECK(glm::dvec3(p[i][3]).x - glm::dvec3(p[i - 1][3]).x == doctest::Approx(step).epsilon(1e-6));
    CHECK(glm::dvec3(p.back()[3]).x == doctest::Approx(glm::dvec3(keys.back()[3]).x));
  }
  SUBCASE("a turn on the spot still interpolates; one key gives copies") {
    const Pass p = interpolate_pass({pose_at(0, 0, 0), pose_at(0, 0, 1.5)}, 11);
    CHECK(std::atan2(p[5][2][1], p[5][2][0]) == doctest::Approx(0.75));
    CHECK(interpolate_pass({pose_at(1, 2, 0)}, 4).size() == 4);
    CHECK_THROWS_AS(interpolate_pass({}, 4), std::invalid_argument);
    CHECK_THROWS_AS(interpolate_pass({pose_at(0, 0, 0)}, 0), std::invalid_argument);
  }
}

TEST_CASE("viewer: saved .npy [P,N,4,4] and JSON passes read back by the trajectory readers") {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "icube_test_viewer";
  std::filesystem::create_directories(dir);
  const std::vector<Pass> passes = {interpolate_pass({pose_at(0, 0, 0), pose_at(30, 5, 0.3)}, 93),
                                    interpolate_pass({pose_at(100, 0, 2), pose_at(80, 20, 2.5)}, 93)};
  const std::string npy = (dir / "run.npy").string();
  save_passes_npy(npy, passes);
  const render::PinholeIntrinsics K = render::intrinsics_of(scene::waymo_front_camera());
  for (size_t i = 0; i < passes.size(); ++i) save_pass_json(pass_json_path(npy, i), passes[i], K);
  CHECK(pass_json_path(npy, 1) == (dir / "run_pass1.json").string());

  const render::TrajectoryFile f = render::load_trajectory(npy, 0);
  REQUIRE(f.passes.size() == 2);
  for (size_t p = 0; p < 2; ++p) {
    REQUIRE(f.passes[p].size() == 93);
    for (size_t i = 0; i < 93; ++i)
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) CHECK(f.passes[p].c2w[i][c][r] == doctest::Approx(passes[p][i][c][r]).epsilon(1e-5));
  }
  const render::TrajectoryFile j = render::load_trajectory(pass_json_path(npy, 1), 50);
  REQUIRE(j.passes.size() == 1);
  REQUIRE(j.camera);
  CHECK(j.camera->width == 832);
  CHECK(j.passes[0].time_index.back() == 49);  // scene states repeat the last one
  CHECK(glm::dvec3(j.passes[0].c2w[92][3]).x == doctest::Approx(passes[1][92][3].x).epsilon(1e-6));
  CHECK(load_passes(npy).size() == 2);
  CHECK_THROWS_AS(save_passes_npy(npy, {passes[0], Pass(5, passes[0][0])}), std::invalid_argument);
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer: script parser") {
  const std::vector<ScriptEvent> ev = parse_script(
      "# drive\n0 down w\n 1.5 up W  # release\n\n2 record pass\n2 save out/a.npy\n3 quit\n", "t.script");
  REQUIRE(ev.size() == 5);
  CHECK(ev[0].command == "down");
  CHECK(ev[0].args[0] == "W");
  CHECK(ev[1].time == 1.5);
  CHECK(ev[1].line == 3);
  CHECK(ev[3].args[0] == "out/a.npy");
  ScriptPlayer player(ev);
  CHECK(player.due(0.0).size() == 1);
  CHECK(player.due(1.0).empty());
  CHECK(player.due(2.0).size() == 3);
  CHECK(!player.done());
  CHECK(player.due(10.0).size() == 1);
  CHECK(player.done());
  CHECK_THROWS_WITH_AS(parse_script("0 fly\n", "x"), "x:1: unknown command 'fly'", std::invalid_argument);
  CHECK_THROWS_WITH_AS(parse_script("1 quit\n0 quit\n", "x"), "x:2: times must not decrease", std::invalid_argument);
  CHECK_THROWS_WITH_AS(parse_script("0 down X\n", "x"), "x:1: unknown key 'X'", std::invalid_argument);
  CHECK_THROWS_WITH_AS(parse_script("0 render foo\n", "x"), "x:1: 'render': unknown argument 'foo'",
                       std::invalid_argument);
  CHECK_THROWS_AS(parse_script("a quit\n", "x"), std::invalid_argument);
  CHECK_THROWS_AS(parse_script("0 scale 2\n", "x"), std::invalid_argument);
  CHECK_THROWS_AS(parse_script("0 up\n", "x"), std::invalid_argument);
  // The Gaussian view's commands.
  const std::vector<ScriptEvent> g =
      parse_script("0 view gaussians\n0 time 12\n0 play on\n1 gaussian-shots out/g 3\n2 view voxels\n", "g");
  REQUIRE(g.size() == 5);
  CHECK(g[1].args[0] == "12");
  CHECK(g[3].args[1] == "3");
  CHECK_THROWS_WITH_AS(parse_script("0 view splats\n", "x"), "x:1: 'view': unknown argument 'splats'",
                       std::invalid_argument);
  CHECK_THROWS_AS(parse_script("0 time -1\n", "x"), std::invalid_argument);
  CHECK_THROWS_AS(parse_script("0 time soon\n", "x"), std::invalid_argument);
  CHECK_THROWS_AS(parse_script("0 gaussian-shots out/g 0\n", "x"), std::invalid_argument);
  CHECK_THROWS_AS(parse_script("0 play maybe\n", "x"), std::invalid_argument);
}

TEST_CASE("viewer: frame-time percentiles (nearest rank)") {
  FrameStats s;
  CHECK(s.percentile(50) == 0.0);
  for (int i = 1; i <= 100; ++i) s.add(i);
  CHECK(s.percentile(50) == 50.0);
  CHECK(s.percentile(90) == 90.0);
  CHECK(s.percentile(99) == 99.0);
  CHECK(s.percentile(100) == 100.0);
  CHECK(s.percentile(0) == 1.0);
  CHECK(s.mean() == doctest::Approx(50.5));
  CHECK(s.summary().find("p95 95.00") != std::string::npos);
}

TEST_CASE("viewer: a recorded drive on the demo town (procedural prior): shape, progress, heights on the ground") {
  const scene::Scene sc = world::make_demo_scene();
  world::ProceduralPrior prior(sc);
  const world::VoxelGrid g = world::build_world(sc, prior).world;
  const scene::Camera cam = scene::waymo_front_camera();
  VehicleLimits lim;
  GroundOptions ground;
  Autopilot ap;
  ap.path = ego_path(sc);
  REQUIRE(ap.path.size() > 10);
  VehicleState car = vehicle_from_ego(sc.ego[0].ego_to_world);
  REQUIRE(settle_vehicle(car, lim, g, ground, car.position.z + 5.0));

  // Pass 1: throttle by hand for 8 s; pass 2: the autopilot for 20 s more. 30 fps, recorded at 10 Hz.
  Recorder rec;
  double t = 0.0;
  const double dt = 1.0 / 30;
  size_t last_progress = 0;
  double max_off = 0.0, speed_there = 0.0;
  glm::dvec3 where(0.0);
  for (int pass = 0; pass < 2; ++pass) {
    rec.start_continuous(t);
    const double end = t + (pass == 0 ? 8.0 : 20.0);
    while (t < end) {
      const VehicleInput in = pass == 0 ? VehicleInput{0.7, 0.0, autopilot_input(ap, car, lim).steer}
                                        : autopilot_input(ap, car, lim);
      CHECK(ap.progress >= last_progress);  // the autopilot never goes back along the track
      last_progress = ap.progress;
      step_vehicle(car, in, dt, lim, &g, ground);
      t += dt;
      rec.update(t, dash_camera_c2w(car, cam));
      // Near the track.
      double nearest = 1e9;
      for (const glm::dvec2& q : ap.path) nearest = std::min(nearest, glm::length(q - glm::dvec2(car.position)));
      if (nearest > max_off) {
        max_off = nearest;
        where = car.position;
        speed_there = car.speed;
      }
    }
    REQUIRE(rec.end_pass());
  }
  INFO("farthest from the track at ", where.x, ", ", where.y, " at ", speed_there, " m/s");
  CHECK(max_off < 3.0);  // stays on the road (the autopilot follows the rear axle)
  REQUIRE(rec.passes().size() == 2);
  CHECK(rec.passes()[0].size() == doctest::Approx(80).epsilon(0.05));
  std::vector<Pass> interp;
  for (const Pass& p : rec.passes()) interp.push_back(interpolate_pass(p, kDefaultInterpolatedFrames));
  PassCheckOptions o;
  o.passes = 2;
  o.min_travel = 20.0;
  o.camera_height = scene::kWaymoFrontMount.z;
  const std::vector<std::string> bad = check_passes(interp, &g, o);
  for (const std::string& b : bad) MESSAGE(b);
  CHECK(bad.empty());
  // The check notices wrong heights and backwards passes.
  Pass lifted = interp[0];
  for (glm::dmat4& m : lifted) m[3].z += 1.0;
  CHECK(!check_passes({lifted}, &g, o).empty());
  Pass reversed(interp[0].rbegin(), interp[0].rend());
  o.passes = 1;
  CHECK(!check_passes({reversed}, nullptr, o).empty());
}
