// Voxel LiDAR (engine/render/lidar/): the model's ray directions (elevations,
// azimuth order, counts, presets, option parsing), a hand-built world (flat
// ground slab + a wall with a car section) against analytic ranges, classes,
// instances, intensities and the range limits, the PLY / KITTI .bin / range
// PNG / poses round trips, and a small procedural demo world for two frames
// with dynamic cars.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "test_world_util.h"
#include "test_stb_image.h"

#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"
#include "render/buffers/trajectory.h"
#include "render/lidar/lidar_io.h"
#include "render/lidar/lidar_model.h"
#include "render/lidar/lidar_scan.h"
#include "render/lidar/lidar_sequence.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "world/car_mesh.h"
#include "world/demo_scene.h"
#include "world/npy.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"

#include <nlohmann/json.hpp>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <set>

using namespace icube;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr uint8_t kCar = 1, kBuilding = 14, kRoad = 18;

std::string temp_dir(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("icube-lidar-" + name + "-" + std::to_string(getpid()));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

double wrap(double a) { return std::remainder(a, 2.0 * kPi); }

}  // namespace

TEST_CASE("lidar model: elevations, azimuth order and ray count") {
  const render::LidarModel w = render::waymo_top_lidar();
  render::validate_lidar(w);
  CHECK(w.beams() == 64);
  CHECK(w.columns == 2650);
  CHECK(w.rays() == 64u * 2650u);
  CHECK(w.max_range == 75.0);
  CHECK(w.sensor_to_ego[3].z == 2.2);
  CHECK(w.elevations_deg.front() == doctest::Approx(2.4));
  CHECK(w.elevations_deg.back() == doctest::Approx(-17.6));
  for (size_t r = 1; r < w.elevations_deg.size(); ++r)
    CHECK(w.elevations_deg[r - 1] - w.elevations_deg[r] == doctest::Approx(20.0 / 63.0));

  const std::vector<glm::dvec3> d = render::lidar_directions(w);
  REQUIRE(d.size() == w.rays());
  for (uint32_t r : {0u, 17u, 63u})
    for (uint32_t c : {0u, 1u, 662u, 1324u, 1325u, 2649u}) {
      const glm::dvec3 v = d[size_t{r} * w.columns + c];
      CHECK(glm::length(v) == doctest::Approx(1.0).epsilon(1e-12));
      CHECK(std::asin(v.z) / kDeg == doctest::Approx(w.elevations_deg[r]).epsilon(1e-9));
      const double want = wrap(kPi - 2.0 * kPi * (c + 0.5) / 2650.0);
      CHECK(wrap(std::atan2(v.y, v.x) - want) == doctest::Approx(0.0).epsilon(1e-12));
    }
  // Column 0 looks backwards (just left of -x), the middle columns forward, a quarter in: left (+y).
  CHECK(d[0].x < -0.99);
  CHECK(d[0].y > 0.0);
  CHECK(d[1324].x > 0.99);
  CHECK(d[1324].y > 0.0);
  CHECK(d[1325].y < 0.0);
  CHECK(d[662].y > 0.99);
  CHECK(d[1987].y < -0.99);
  // Azimuth strictly decreasing along a row (clockwise spin), one full turn.
  double total = 0.0;
  for (uint32_t c = 1; c < w.columns; ++c) {
    const double step = wrap(std::atan2(d[c].y, d[c].x) - std::atan2(d[c - 1].y, d[c - 1].x));
    CHECK(step == doctest::Approx(-2.0 * kPi / 2650.0).epsilon(1e-9));
    total += step;
  }
  CHECK(total == doctest::Approx(-2.0 * kPi * 2649.0 / 2650.0));

  // Uniform ranges and explicit lists.
  CHECK(render::uniform_elevations(1, -5, 5) == std::vector<double>{5.0});
  CHECK(render::uniform_elevations(3, -10, 2) == std::vector<double>{2.0, -4.0, -10.0});
  CHECK(render::parse_elevation_list("-3,1.5,0") == std::vector<double>{1.5, 0.0, -3.0});
  double lo = 0, hi = 0;
  render::parse_min_max("-17.6:2.4", "--elevation", &lo, &hi);
  CHECK(lo == -17.6);
  CHECK(hi == 2.4);
  CHECK_THROWS_AS(render::parse_min_max("5:1", "--range", &lo, &hi), std::invalid_argument);
  CHECK_THROWS_AS(render::parse_min_max("1", "--range", &lo, &hi), std::invalid_argument);
  CHECK_THROWS_AS(render::parse_min_max("a:3", "--range", &lo, &hi), std::invalid_argument);
  CHECK_THROWS_AS(render::parse_elevation_list("1,,2"), std::invalid_argument);
  CHECK_THROWS_AS(render::lidar_preset("velodyne"), std::invalid_argument);
  render::LidarModel bad = w;
  bad.elevations_deg = {1.0, 1.0};
  CHECK_THROWS_AS(render::validate_lidar(bad), std::invalid_argument);
  bad = w;
  bad.columns = 0;
  CHECK_THROWS_AS(render::validate_lidar(bad), std::invalid_argument);
  bad = w;
  bad.max_range = 700;
  CHECK_THROWS_AS(render::validate_lidar(bad), std::invalid_argument);
  bad = w;
  bad.sensor_to_ego[0][0] = 2.0;
  CHECK_THROWS_AS(render::validate_lidar(bad), std::invalid_argument);
}

namespace {

// Ground slab: voxels k = -2, -1 (z in [-0.4, 0)) over x, y in [-12, 12). Wall: x in [10, 10.4),
// y in [-10, 10), z in [0, 5); its part y in [0, 2) is a car (instance 10001), the rest building.
world::VoxelGrid ground_and_wall() {
  world::VoxelGrid g({0.0, 0.0, 0.0});
  for (int i = -60; i < 60; ++i)
    for (int j = -60; j < 60; ++j)
      for (int k = -2; k < 0; ++k) g.set({i, j, k}, kRoad);
  for (int i = 50; i < 52; ++i)
    for (int j = -50; j < 50; ++j)
      for (int k = 0; k < 25; ++k) {
        const bool car = j >= 0 && j < 10;
        g.set({i, j, k}, car ? kCar : kBuilding, car ? 10001 : 0);
      }
  return g;
}

struct Expected {
  bool hit = false, ambiguous = false;
  double range = 0.0;
  uint8_t cls = 0;
  uint16_t instance = 0;
  double cos_incidence = 0.0;
};

// The first surface along sensor origin s, direction d; `ambiguous` within `m` metres of an edge.
Expected analytic(const glm::dvec3& s, const glm::dvec3& d) {
  constexpr double m = 0.05;
  Expected e;
  double best = INFINITY;
  auto near = [&](double v, double edge) { return std::fabs(v - edge) < m; };
  if (d.z < 0.0) {
    const double t = -s.z / d.z;
    const glm::dvec3 p = s + t * d;
    if (near(std::fabs(p.x), 12.0) || near(std::fabs(p.y), 12.0)) e.ambiguous = true;
    if (std::fabs(p.x) < 12.0 && std::fabs(p.y) < 12.0 && t < best) {
      best = t;
      e = {true, e.ambiguous, t, kRoad, 0, -d.z};
    }
  }
  if (d.x > 0.0) {
    const double t = (10.0 - s.x) / d.x;
    const glm::dvec3 p = s + t * d;
    if (near(p.y, -10.0) || near(p.y, 10.0) || near(p.z, 5.0) || near(p.z, 0.0) || near(p.y, 0.0) || near(p.y, 2.0))
      e.ambiguous = e.ambiguous || t < best + m;
    if (p.y >= -10.0 && p.y < 10.0 && p.z >= 0.0 && p.z < 5.0 && t < best) {
      const bool car = p.y >= 0.0 && p.y < 2.0;
      best = t;
      e = {true, e.ambiguous, t, car ? kCar : kBuilding, static_cast<uint16_t>(car ? 10001 : 0), d.x};
    }
  }
  return e;
}

render::LidarModel test_model() {
  render::LidarModel m;
  m.elevations_deg = {3.0, 0.5, -5.0, -10.0, -20.0, -35.0};
  m.columns = 360;
  m.min_range = 0.5;
  m.max_range = 40.0;
  m.sensor_to_ego = render::lidar_mount(1.73);
  return m;
}

}  // namespace

TEST_CASE("lidar: a ground slab and a wall give the analytic ranges, classes, instances and intensities") {
  const world::VoxelGrid g = ground_and_wall();
  render::OverlayWorld ow(test::gpu_context(), g);
  glm::dmat4 ego(1.0);
  ego[3] = {0.03, 0.07, 0.0, 1.0};  // off the lattice planes
  const render::LidarModel m = test_model();
  const glm::dmat4 s2w = ego * m.sensor_to_ego;
  const glm::dvec3 origin(s2w[3]);
  CHECK(origin.z == doctest::Approx(1.73));
  render::LidarCaster caster(test::gpu_context(), m);
  const render::LidarScan scan = caster.cast(ow.world(), s2w);
  CHECK(scan.beams == 6);
  CHECK(scan.columns == 360);
  REQUIRE(scan.range.size() == 6 * 360);
  // Tolerance: the kernel works in float relative to the sensor's voxel; a float t at <= 40 m is
  // good to ~5e-6 m, float directions (~6e-8 rad) move a grazing ground hit (-5 deg, 19.8 m) by
  // h cos e / sin^2 e · 6e-8 ~ 1.4e-5 m. 2e-4 m (1/1000 voxel) bounds both with a wide margin.
  constexpr double kTol = 2e-4;
  size_t checked = 0, ambiguous = 0, ground = 0, wall = 0, car = 0;
  double max_err = 0.0;
  std::vector<const render::LidarReturn*> by_ray(scan.range.size(), nullptr);
  for (const auto& r : scan.returns) by_ray[size_t{r.ring} * m.columns + r.column] = &r;
  const std::vector<glm::dvec3>& dirs = caster.directions();
  for (size_t i = 0; i < dirs.size(); ++i) {
    const Expected e = analytic(origin, dirs[i]);
    if (e.ambiguous) {
      ++ambiguous;
      continue;
    }
    INFO("ray " << i << " (ring " << i / 360 << ", column " << i % 360 << ")");
    const render::LidarReturn* r = by_ray[i];
    REQUIRE((r != nullptr) == e.hit);
    ++checked;
    if (!r) {
      CHECK(scan.range[i] == 0.0f);
      continue;
    }
    CHECK(std::fabs(static_cast<double>(r->range) - e.range) <= kTol);
    max_err = std::max(max_err, std::fabs(static_cast<double>(r->range) - e.range));
    CHECK(scan.range[i] == r->range);
    CHECK(r->class_id == e.cls);
    CHECK(r->instance == e.instance);
    CHECK(static_cast<double>(r->intensity) ==
          doctest::Approx(static_cast<double>(render::lidar_reflectivity(e.cls)) * e.cos_incidence).epsilon(1e-5));
    const glm::dvec3 ps = static_cast<double>(r->range) * dirs[i];
    CHECK(glm::length(glm::dvec3(r->sensor) - ps) < 1e-5);
    CHECK(glm::length(r->world - glm::dvec3(s2w * glm::dvec4(ps, 1.0))) < 1e-9);
    ground += e.cls == kRoad;
    wall += e.cls != kRoad;
    car += e.cls == kCar;
  }
  MESSAGE("checked " << checked << " rays (" << ambiguous << " near an edge skipped): " << ground << " ground, " << wall
                     << " wall (" << car << " car), max range error " << max_err << " m");
  CHECK(ambiguous < 60);
  CHECK(ground > 600);
  CHECK(wall > 50);
  CHECK(car >= 5);
  // Ground rings where the ground is all around: r = h / sin(-e) for every column.
  for (uint32_t ring : {4u, 5u}) {
    const double want = 1.73 / std::sin(-m.elevations_deg[ring] * kDeg);
    for (uint32_t c = 0; c < m.columns; ++c) CHECK(std::fabs(static_cast<double>(scan.range[ring * 360 + c]) - want) <= kTol);
  }
  // The forward columns of ring 1 (0.5 deg) see the wall at 9.97 / cos(e) / cos(a).
  const double a179 = render::lidar_column_azimuth(m, 179);
  CHECK(std::fabs(static_cast<double>(scan.range[360 + 179]) - 9.97 / std::cos(0.5 * kDeg) / std::cos(a179)) <= kTol);
  CHECK(by_ray[360 + 179]->class_id == kCar);   // azimuth +0.5 deg: y > 0, the car part
  CHECK(by_ray[360 + 180]->class_id == kBuilding);  // -0.5 deg

  // Limits: max range 8 keeps only returns up to 8 m (the wall at ~10 m and ring 3's 9.96 m go);
  // min range 4 drops ring 5 (3.02 m).
  render::LidarModel near_model = m;
  near_model.max_range = 8.0;
  near_model.min_range = 4.0;
  render::LidarCaster near_caster(test::gpu_context(), near_model);
  const render::LidarScan near_scan = near_caster.cast(ow.world(), s2w);
  size_t kept = 0;
  for (size_t i = 0; i < scan.range.size(); ++i) {
    const float full = scan.range[i];
    const bool want = full >= 4.0f && full <= 8.0f;
    if (full == 0.0f || std::fabs(full - 4.0f) < 1e-3f || std::fabs(full - 8.0f) < 1e-3f) continue;
    CHECK((near_scan.range[i] > 0.0f) == want);
    if (want) CHECK(near_scan.range[i] == full);
    kept += want;
  }
  CHECK(kept == 360);  // ring 4 (-20 deg, 5.06 m) only
  CHECK(near_scan.returns.size() == kept);
  for (const auto& r : near_scan.returns) CHECK(r.ring == 4);
}

TEST_CASE("lidar: PLY, KITTI .bin, range PNGs and poses read back") {
  const world::VoxelGrid g = ground_and_wall();
  render::OverlayWorld ow(test::gpu_context(), g);
  const render::LidarModel m = test_model();
  render::LidarCaster caster(test::gpu_context(), m);
  glm::dmat4 s2w = m.sensor_to_ego;
  s2w[3].x = 0.03;
  render::LidarScan scan = caster.cast(ow.world(), s2w);
  scan.frame_index = 42;
  REQUIRE(scan.returns.size() > 1000);
  const std::string dir = temp_dir("io");
  render::write_lidar_frame(dir, scan, m, {});

  const std::string ply = scene::read_file(dir + "/ply/000042.ply");
  const auto pts = render::parse_lidar_ply(ply, "ply");
  REQUIRE(pts.size() == scan.returns.size());
  CHECK(ply.find("format binary_little_endian 1.0\n") != std::string::npos);
  for (size_t i = 0; i < pts.size(); ++i) {
    const render::LidarReturn& r = scan.returns[i];
    CHECK(pts[i].x == r.sensor.x);
    CHECK(pts[i].y == r.sensor.y);
    CHECK(pts[i].z == r.sensor.z);
    CHECK(pts[i].intensity == r.intensity);
    CHECK(pts[i].class_id == r.class_id);
    CHECK(pts[i].instance == r.instance);
    CHECK(pts[i].ring == r.ring);
    CHECK(pts[i].range == r.range);
  }
  // Byte layout of the first vertex: little-endian float x at the start of the body.
  const size_t body = ply.find("end_header\n") + 11;
  CHECK(ply.size() - body == pts.size() * 25);
  float x0 = 0;
  std::memcpy(&x0, ply.data() + body, 4);
  CHECK(x0 == scan.returns[0].sensor.x);
  const auto wpts = render::parse_lidar_ply(render::encode_lidar_ply(scan, true), "ply-world");
  CHECK(wpts[7].x == static_cast<float>(scan.returns[7].world.x));
  CHECK_THROWS_AS(render::parse_lidar_ply(ply.substr(0, ply.size() - 1), "short"), scene::InputError);

  const auto bin = render::parse_kitti_bin(scene::read_file(dir + "/bin/000042.bin"), "bin");
  REQUIRE(bin.size() == scan.returns.size());
  for (size_t i = 0; i < bin.size(); ++i) {
    CHECK(bin[i][0] == scan.returns[i].sensor.x);
    CHECK(bin[i][1] == scan.returns[i].sensor.y);
    CHECK(bin[i][2] == scan.returns[i].sensor.z);
    CHECK(bin[i][3] == scan.returns[i].intensity);
    CHECK(bin[i][3] >= 0.0f);
    CHECK(bin[i][3] <= 1.0f);
  }
  CHECK(std::filesystem::file_size(dir + "/bin/000042.bin") == 16 * scan.returns.size());

  const std::string png = scene::read_file(dir + "/range/000042.png");
  int w = 0, h = 0, ch = 0;
  stbi_us* px = stbi_load_16_from_memory(reinterpret_cast<const stbi_uc*>(png.data()), static_cast<int>(png.size()), &w,
                                          &h, &ch, 1);
  REQUIRE(px != nullptr);
  CHECK(w == 360);
  CHECK(h == 6);
  size_t zero = 0;
  for (size_t i = 0; i < scan.range.size(); ++i) {
    CHECK(px[i] == static_cast<uint16_t>(std::trunc(static_cast<double>(scan.range[i]) * 100.0)));
    zero += px[i] == 0;
  }
  CHECK(zero == scan.range.size() - scan.returns.size());
  // Ring 4 is ground at 1.73 / sin 20 deg = 5.058 m everywhere: 505 cm.
  CHECK(px[4 * 360 + 17] == 505);
  stbi_image_free(px);
  const std::string cpng = scene::read_file(dir + "/range_color/000042.png");
  stbi_uc* rgb = stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(cpng.data()), static_cast<int>(cpng.size()), &w,
                                       &h, &ch, 3);
  REQUIRE(rgb != nullptr);
  const uint32_t rep = render::range_view_row_repeat(6);
  CHECK(rep == 8);
  CHECK(w == 360);
  CHECK(h == static_cast<int>(6 * rep));
  const auto want = render::lidar_range_colour(static_cast<double>(scan.range[4 * 360 + 17]), 40.0);
  for (uint32_t k = 0; k < rep; ++k)
    for (int c = 0; c < 3; ++c) CHECK(rgb[((4 * rep + k) * 360 + 17) * 3 + static_cast<uint32_t>(c)] == want[static_cast<size_t>(c)]);
  stbi_image_free(rgb);
  CHECK(render::lidar_range_colour(0.0, 40.0) == std::array<uint8_t, 3>{0, 0, 0});

  std::vector<glm::dmat4> poses = {s2w, glm::dmat4(1.0)};
  poses[1][3] = {1e5, -2e5, 3.25, 1.0};
  scene::write_file_atomic(dir + "/poses.npy", render::lidar_poses_npy(poses));
  const world::NpyArray a = world::read_npy(dir + "/poses.npy");
  CHECK(a.dtype == world::NpyDtype::F8);
  CHECK(a.shape == std::vector<uint64_t>{2, 4, 4});
  CHECK(a.as_double(16 + 3) == 1e5);   // row 0, column 3 of pose 1
  CHECK(a.as_double(16 + 7) == -2e5);
  CHECK(a.as_double(11) == 1.73);      // pose 0: z of the translation
  const nlohmann::json meta = nlohmann::json::parse(render::lidar_meta_json(m, {0, 1}, {}, "test"));
  CHECK(meta["beams"] == 6);
  CHECK(meta["elevations_deg"][5].get<double>() == -35.0);
  std::filesystem::remove_all(dir);
}


TEST_CASE("lidar: two frames of the procedural demo world with dynamic cars") {
  using Clock = std::chrono::steady_clock;
  const scene::Scene s = world::make_demo_scene();
  const world::ProceduralPrior prior(s);
  const test::FirstChunks gen(prior, 2);
  world::WorldBuildOptions bo;
  bo.threads = 2;
  const world::WorldBuildResult built = world::build_world(s, gen, bo);
  const world::TriangleMesh mesh = world::builtin_car_mesh();
  const world::VoxelGrid stat = render::make_static_world(built.world, s, 0, mesh);
  render::LidarModel m = render::waymo_top_lidar();
  m.elevations_deg = render::uniform_elevations(16, render::kWaymoTopElevationMinDeg, render::kWaymoTopElevationMaxDeg);
  m.columns = 512;
  const render::Trajectory full = render::lidar_ego_trajectory(s, m.sensor_to_ego);
  REQUIRE(full.size() > 40);
  CHECK(full.c2w[0][3].z == doctest::Approx(s.ego[0].ego_to_world[3].z + 2.2));
  const render::Trajectory traj = render::select_frames(full, render::parse_frame_range("0:40:30"));
  REQUIRE(traj.size() == 2);
  render::OverlayWorld ow(test::gpu_context(), stat);
  std::vector<render::LidarScan> scans;
  size_t progress = 0;
  render::LidarSequenceOptions so;
  so.on_frame = [&](const render::LidarScan& sc) { scans.push_back(sc); };
  so.progress = [&](size_t, size_t) { ++progress; };
  const render::LidarSequenceStats st = render::cast_lidar_sequence(test::gpu_context(), ow, &s, mesh, m, traj, so);
  REQUIRE(scans.size() == 2);
  CHECK(progress == 2);
  CHECK(st.rays == 2 * 16 * 512);
  CHECK(scans[1].frame_index == 30);
  CHECK(scans[1].time_index == 30);
  std::set<uint16_t> dynamic;
  for (const render::LidarScan& sc : scans) {
    size_t road = 0, bad = 0;
    for (const auto& r : sc.returns) {
      road += r.class_id == kRoad;
      if (r.instance >= 10000) dynamic.insert(r.instance);
      bad += !(r.range >= 0.5f && r.range <= 75.0f && r.intensity >= 0.0f && r.intensity <= 1.0f);
      bad += glm::length(r.world - glm::dvec3(sc.sensor_to_world * glm::dvec4(glm::dvec3(r.sensor), 1.0))) > 1e-4;
    }
    CHECK(bad == 0);
    CHECK(sc.returns.size() > 16 * 512 / 3);
    CHECK(road > 512);  // the downward beams all around the car
    // Ring 15 (-17.6 deg) on the flat demo road: r = (sensor z - road top) / sin 17.6 deg, the road top
    // read from the static world's column under the sensor (the demo road voxels span z in [0, 0.2)).
    const glm::dvec3 o(sc.sensor_to_world[3]);
    const glm::ivec3 ij = glm::ivec3(glm::floor((o - stat.origin()) / stat.voxel_size()));
    int top = INT32_MIN;
    for (int k = ij.z; k > ij.z - 100; --k)
      if (stat.get({ij.x, ij.y, k}).class_id == kRoad) {
        top = k;
        break;
      }
    REQUIRE(top != INT32_MIN);
    const double road_z = stat.origin().z + (top + 1) * stat.voxel_size();
    const double want = (o.z - road_z) / std::sin(17.6 * kDeg);
    size_t near_ground = 0, ring15 = 0;
    for (const auto& r : sc.returns)
      if (r.ring == 15 && r.class_id == kRoad) {
        ++ring15;
        near_ground += std::fabs(static_cast<double>(r.range) - want) < 2e-4;
      }
    CHECK(near_ground > ring15 * 8 / 10);
  }
  // Dynamic cars (instance >= 10000) are hit in at least one of the frames.
  CHECK(!dynamic.empty());
  MESSAGE("demo: returns " << scans[0].returns.size() << ", " << scans[1].returns.size() << "; dynamic instances hit: "
                           << dynamic.size());

  // The waymo-top preset on the same world, one sweep: timing for the report.
  render::LidarCaster wt(test::gpu_context(), render::waymo_top_lidar());
  const auto t0 = Clock::now();
  const render::LidarScan sw = wt.cast(ow.world(), traj.c2w[0]);
  const double sec = std::chrono::duration<double>(Clock::now() - t0).count();
  CHECK(sw.returns.size() > 64 * 2650 / 3);
  MESSAGE("waymo-top sweep: " << 64 * 2650 << " rays, " << sw.returns.size() << " returns, " << sec * 1e3
                              << " ms total (dispatch " << wt.cast_s * 1e3 << " ms: "
                              << 64 * 2650 / wt.cast_s * 1e-6 << " Mrays/s)");
}
