// Guidance buffers, CPU parts (engine/render/buffers/): PuRd LUT and seeded
// instance colours, ustar round trip, quantiles and coordinate normalisation
// on known points (including the all-equal 1e-7 guard), trajectory files,
// frame ranges and cameras. GPU rendering: test_guidance_buffers_render.cpp.
#include <doctest/doctest.h>

#include "render/buffers/coordinate_buffer.h"
#include "render/buffers/guidance_frame.h"
#include "render/camera.h"
#include "render/buffers/instance_colors.h"
#include "render/buffers/tar_archive.h"
#include "render/buffers/trajectory.h"
#include "scene/atomic_file.h"
#include "scene/frames.h"
#include "scene/input_error.h"
#include "world/npy.h"

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

using namespace icube;
using render::Rgb8;

namespace {

std::string temp_dir(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("icube-gb-" + name + "-" + std::to_string(getpid()));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

Rgb8 rgb_at(const std::vector<uint8_t>& img, size_t i) { return {img[3 * i], img[3 * i + 1], img[3 * i + 2]}; }

}  // namespace

TEST_CASE("guidance buffers: PuRd LUT anchors and a hand-interpolated entry") {
  const auto& lut = render::purd_lut();
  CHECK(lut[0] == Rgb8{247, 244, 249});
  CHECK(lut[255] == Rgb8{103, 0, 31});
  // Index 128 lies between anchors 4 (#df65b0 at 127.5) and 5 (#e7298a at 159.375):
  // w = 0.5 / 31.875; r = 223 + 8w, g = 101 - 60w, b = 176 - 38w, truncated.
  CHECK(lut[128] == Rgb8{223, 100, 175});
  // Index 32 (anchor 1 #e7e1ef at 31.875, next #d4b9da): w = 0.125 / 31.875.
  CHECK(lut[32] == Rgb8{230, 224, 238});
}

TEST_CASE("guidance buffers: instance colours come from the seeded generator, one per unique id") {
  const std::vector<uint16_t> ids{10001, 0, 3, 10001, 1};
  const auto c = render::instance_colors(ids, 42);
  REQUIRE(c.size() == 3);
  CHECK(c.count(0) == 0);
  std::mt19937_64 rng(42);  // ids in increasing order: 1, 3, 10001
  for (uint16_t id : {uint16_t{1}, uint16_t{3}, uint16_t{10001}}) {
    const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;
    CHECK(c.at(id) == render::purd_lut()[static_cast<size_t>(u * 256.0)]);
  }
  CHECK(render::instance_colors(ids, 42) == c);
  CHECK(render::instance_colors(ids, 43) != c);
}

TEST_CASE("guidance buffers: ustar archives round trip and carry valid headers") {
  render::TarWriter w;
  const std::string long_dir(120, 'd');
  w.add("clip.000000.voxel_depth_100.front.png", std::string("\x89PNG\0\1", 6));
  w.add("empty.json", "");
  w.add("exact.bin", std::string(512, 'x'));
  w.add("over.bin", std::string(513, 'y'));
  w.add(long_dir + "/member.npy", "abc");
  CHECK_THROWS_AS(w.add(std::string(160, 'n'), "x"), std::invalid_argument);
  CHECK_THROWS_AS(w.add("", "x"), std::invalid_argument);
  const std::string bytes = w.bytes();
  CHECK(bytes.size() % 512 == 0);
  CHECK(bytes.size() == 512 * (5 + 1 + 0 + 1 + 2 + 1) + 1024);
  CHECK(bytes.substr(bytes.size() - 1024) == std::string(1024, '\0'));
  // First header by hand: size field, mtime 0, magic, checksum.
  CHECK(std::memcmp(bytes.data() + 124, "00000000006", 12) == 0);
  CHECK(std::memcmp(bytes.data() + 136, "00000000000", 12) == 0);
  CHECK(std::memcmp(bytes.data() + 257, "ustar\0" "00", 8) == 0);
  unsigned sum = 0;
  for (size_t i = 0; i < 512; ++i) sum += (i >= 148 && i < 156) ? 32u : static_cast<unsigned char>(bytes[i]);
  CHECK(std::strtoul(std::string(bytes.data() + 148, 6).c_str(), nullptr, 8) == sum);
  const auto m = render::parse_tar(bytes);
  REQUIRE(m.size() == 5);
  CHECK(m[0].name == "clip.000000.voxel_depth_100.front.png");
  CHECK(m[0].data == std::string("\x89PNG\0\1", 6));
  CHECK(m[1].data.empty());
  CHECK(m[2].data == std::string(512, 'x'));
  CHECK(m[3].data == std::string(513, 'y'));
  CHECK(m[4].name == long_dir + "/member.npy");
  CHECK(m[4].data == "abc");
  CHECK(w.bytes() == bytes);  // deterministic
  std::string bad = bytes;
  bad[0] = 'X';
  CHECK_THROWS_AS(render::parse_tar(bad), std::runtime_error);
  CHECK_THROWS_AS(render::parse_tar(bytes.substr(0, 700)), std::runtime_error);
}

TEST_CASE("guidance buffers: quantiles and coordinate normalisation on known points") {
  std::vector<double> v{4, 1, 3, 2};
  CHECK(render::quantile_linear(v, 0.05) == doctest::Approx(1.15));
  CHECK(render::quantile_linear(v, 0.95) == doctest::Approx(3.85));
  std::vector<double> one{7.0};
  CHECK(render::quantile_linear(one, 0.95) == 7.0);

  // x = 0..100, y = 5 everywhere (all equal), z = 10 + x.
  std::vector<glm::dvec3> pts;
  for (int i = 0; i <= 100; ++i) pts.push_back({i, 5.0, 10.0 + i});
  const render::CoordinateRange r = render::coordinate_range_of(pts);
  CHECK(r.min.x == doctest::Approx(5.0));
  CHECK(r.range.x == doctest::Approx(90.0));
  CHECK(r.min.y == 5.0);
  CHECK(r.range.y == render::kCoordinateMinRange);  // the 1e-7 guard
  CHECK(r.min.z == doctest::Approx(15.0));

  // Encode 4 pixels: x = 50 (mid), x = 0 (clamped low), x = 100 (clamped high), and a sky pixel.
  const std::vector<float> points{50, 5, 60, 0, 5, 10, 100, 5, 110, 0, 0, 0};
  const std::vector<float> z{60, 10, 110, 0};
  const std::vector<uint8_t> rgb = render::encode_coordinates(points, z, r);
  CHECK(rgb_at(rgb, 0) == Rgb8{127, 0, 127});  // (2·45/90 - 1 + 1)/2 · 255 = 127.5 -> 127; y equal -> -1 -> 0
  CHECK(rgb_at(rgb, 1) == Rgb8{0, 0, 0});
  CHECK(rgb_at(rgb, 2) == Rgb8{255, 0, 255});
  CHECK(rgb_at(rgb, 3) == Rgb8{255, 255, 255});  // sky is white

  // Sampling: fewer valid points than the budget uses all; the seed picks the subset otherwise.
  render::PinholeIntrinsics K{1, 1, 0, 0, 4, 1};
  const std::vector<float> d0{1, 0, 2, 3}, d1{4, 5, 0, 6};
  const std::vector<glm::dmat4> rel{glm::dmat4(1.0), glm::dmat4(1.0)};
  const auto all = render::coordinate_range(K, {&d0, &d1}, rel, render::PixelConvention::Integer, 1);
  CHECK(all.samples == 6);
  CHECK(all.min.z == doctest::Approx(1.25));  // z = {1,2,3,4,5,6}: pos 0.25
  const auto some = render::coordinate_range(K, {&d0, &d1}, rel, render::PixelConvention::Integer, 1, 3);
  CHECK(some.samples == 3);
  CHECK(render::coordinate_range(K, {&d0, &d1}, rel, render::PixelConvention::Integer, 1, 3).min ==
        some.min);
}

TEST_CASE("guidance buffers: trajectories from .npy and JSON, frame ranges, cameras") {
  const std::string dir = temp_dir("traj");
  std::vector<double> two(2 * 3 * 16, 0.0);
  for (size_t m = 0; m < 6; ++m)
    for (int d = 0; d < 4; ++d) two[m * 16 + static_cast<size_t>(5 * d)] = 1.0;
  two[1 * 16 + 3] = 7.0;  // pass 0, pose 1: x = 7
  world::write_npy(dir + "/multi.npy", world::NpyArray::make<double>({2, 3, 4, 4}, two));
  const render::TrajectoryFile tf = render::load_trajectory(dir + "/multi.npy", 2);
  REQUIRE(tf.passes.size() == 2);
  CHECK(tf.passes[0].c2w[1][3].x == 7.0);
  CHECK(tf.passes[1].time_index == std::vector<int>{0, 1, 1});  // past the scene: the last state
  scene::write_file_atomic(dir + "/t.json",
                           R"({"format": "icube-trajectory", "version": 1,
                               "camera": {"fx": 50, "fy": 50, "cx": 32, "cy": 24, "width": 64, "height": 48},
                               "poses": [[[1,0,0,1],[0,1,0,2],[0,0,1,3],[0,0,0,1]]]})");
  const render::TrajectoryFile tj = render::load_trajectory(dir + "/t.json", 0);
  REQUIRE(tj.camera.has_value());
  CHECK(tj.camera->width == 64);
  CHECK(tj.passes[0].c2w[0][3] == glm::dvec4(1, 2, 3, 1));
  CHECK(tj.passes[0].time_index[0] == -1);
  scene::write_file_atomic(dir + "/bad.json", R"({"format": "icube-trajectory", "version": 1, "poses": [[[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]]})");
  CHECK_THROWS_AS(render::load_trajectory(dir + "/bad.json", 0), scene::InputError);
  // Keys of the wrong type are input errors too (fuzz_splat_files found "format": 1 escaping as
  // nlohmann's type_error).
  for (const char* doc : {R"({"format": 1, "version": 1, "poses": []})",
                          R"({"format": "icube-trajectory", "version": "1", "poses": []})",
                          R"({"format": "icube-trajectory", "version": 1.5, "poses": []})"}) {
    scene::write_file_atomic(dir + "/typed.json", doc);
    CHECK_THROWS_AS(render::load_trajectory(dir + "/typed.json", 0), scene::InputError);
  }
  world::write_npy(dir + "/bad.npy", world::NpyArray::make<float>({3, 4}, std::vector<float>(12, 0.0f)));
  CHECK_THROWS_AS(render::load_trajectory(dir + "/bad.npy", 0), scene::InputError);
  const auto r = render::parse_frame_range("3:5");
  CHECK(render::select_frames(tf.passes[0], render::parse_frame_range("1:")).size() == 2);
  CHECK_THROWS_AS(render::select_frames(tf.passes[0], r), std::invalid_argument);
  CHECK_THROWS_AS(render::parse_frame_range("5:2"), std::invalid_argument);
  CHECK(render::parse_frame_range("0:10:3").step == 3);
  CHECK(render::parse_frame_range("::2").end == -1);
  CHECK_THROWS_AS(render::parse_frame_range("0:10:0"), std::invalid_argument);
  {
    render::Trajectory seven;
    for (int i = 0; i < 7; ++i) {
      seven.c2w.push_back(glm::dmat4(1.0));
      seven.frame_index.push_back(i);
      seven.time_index.push_back(i);
    }
    const render::Trajectory every3 = render::select_frames(seven, render::parse_frame_range("1::3"));
    REQUIRE(every3.size() == 2);
    CHECK(every3.frame_index[0] == 1);
    CHECK(every3.frame_index[1] == 4);
  }
  const render::PinholeIntrinsics K = render::parse_camera("100,110,51.5,29.5,104,60");
  CHECK(K.fy == 110.0);
  CHECK(K.height == 60);
  CHECK_THROWS_AS(render::parse_camera("1,2,3"), std::invalid_argument);
  const scene::Camera p = render::camera_preset("waymo-front-480p");
  CHECK(p.width == 832);
  CHECK(p.height == 480);
  std::filesystem::remove_all(dir);
}

TEST_CASE("guidance buffers: a route along the lanes as the trajectory, timed by the scene") {
  scene::Scene s;
  s.provenance.source_file = "straight.json";
  scene::Lane l;
  l.id = 7;
  l.type = scene::LaneType::SurfaceStreet;
  for (int i = 0; i <= 100; ++i) l.points.emplace_back(static_cast<double>(i), 5.0, 1.0);
  s.map.lanes.push_back(l);
  s.timestamps = {0.0, 0.1, 0.2, 0.3};
  scene::RouteOptions ro;
  ro.length_m = 30.0;
  ro.speed_mps = 10.0;
  scene::RouteReport rep;
  const scene::Camera cam = render::camera_preset("waymo-front-480p");
  const render::Trajectory t = render::route_trajectory(s, cam, ro, &rep);
  REQUIRE(t.size() == 31);  // 30 m at 1 m per pose (10 m/s, 10 Hz), both ends included
  CHECK(rep.lanes == std::vector<int64_t>{7});
  for (size_t i = 0; i < t.size(); ++i) {
    CHECK(t.frame_index[i] == static_cast<int>(i));
    CHECK(t.time_index[i] == static_cast<int>(std::min<size_t>(i, 3)));  // past the scene: its last state
    // Camera forward (OpenCV +z) along +x, down (+y) along world -z; position = lane point + mount.
    const glm::dvec3 fwd(t.c2w[i][2]), down(t.c2w[i][1]), pos(t.c2w[i][3]);
    CHECK(fwd.x == doctest::Approx(1.0).epsilon(1e-9));
    CHECK(down.z == doctest::Approx(-1.0).epsilon(1e-9));
    const glm::dvec3 mount = glm::dvec3(cam.camera_to_ego[3]);
    CHECK(pos.x == doctest::Approx(static_cast<double>(t.frame_index[i]) + mount.x).epsilon(1e-6));
    CHECK(pos.y == doctest::Approx(5.0 + mount.y).epsilon(1e-6));
    CHECK(pos.z == doctest::Approx(1.0 + mount.z).epsilon(1e-6));
  }
  scene::Scene no_lanes;
  no_lanes.provenance.source_file = "empty.json";
  CHECK_THROWS_AS(render::route_trajectory(no_lanes, cam, ro), scene::InputError);
}

TEST_CASE("guidance buffers: camera_from_scene gives InfiniCube's OpenCV camera-to-world") {
  scene::Camera cam = render::camera_preset("waymo-front-480p");
  cam.camera_to_ego[3] = glm::dvec4(1.5, 0.1, 2.0, 1.0);
  scene::EgoPose ego;
  ego.ego_to_world = glm::dmat4(glm::dvec4(0, 1, 0, 0), glm::dvec4(-1, 0, 0, 0), glm::dvec4(0, 0, 1, 0),
                                glm::dvec4(100, 200, 3, 1));  // heading +90 degrees
  const render::Camera c = render::camera_from_scene(cam, ego.ego_to_world);
  const glm::dmat4 want = scene::camera_to_world_opencv(ego, cam);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) CHECK(c.c2w[i][j] == doctest::Approx(want[i][j]).epsilon(1e-12));
  // The optical axis (OpenCV +z) looks along the ego's forward axis (world +y here).
  CHECK(c.c2w[2][1] == doctest::Approx(1.0));
}

TEST_CASE("guidance buffers: depth centimetres are numpy's (depth * 100).astype(uint16) on float32 depth") {
  // 0.29f * 100 is 28.99999917 in exact arithmetic, which rounds to 29.0f in float32 (as numpy computes
  // it); a double product would truncate to 28. The same holds for the other values chosen here.
  const std::vector<float> z = {0.29f, 0.57f, 1.13f, 10.055f, 12.3f, 0.0f, 0.004f, 655.35f, 700.0f, -1.0f};
  const std::vector<uint16_t> cm = render::depth_centimetres(z);
  const std::vector<uint16_t> want = {29, 57, 113, 1005, 1230, 0, 0, 65534, 65535, 0};  // 655.35f < 655.35
  CHECK(cm == want);
  // The double route differs on the first three: this test would catch a return to it.
  CHECK(static_cast<int>(std::trunc(static_cast<double>(0.29f) * 100.0)) == 28);
  CHECK(static_cast<int>(std::trunc(static_cast<double>(0.57f) * 100.0)) == 56);
  CHECK(static_cast<int>(std::trunc(static_cast<double>(1.13f) * 100.0)) == 112);
  // Every float in [0, 655) whose product rounds across an integer follows the float32 rule.
  std::vector<float> sweep;
  for (float v = 0.0f; v < 655.0f; v = std::nextafter(v + 0.00731f, 1e9f)) sweep.push_back(v);
  const std::vector<uint16_t> swept = render::depth_centimetres(sweep);
  for (size_t i = 0; i < sweep.size(); ++i) {
    const float p = sweep[i] * 100.0f;
    if (swept[i] != static_cast<uint16_t>(p)) {
      FAIL_CHECK("depth " << sweep[i] << " m gives " << swept[i] << " cm, float32 rule " << static_cast<uint16_t>(p));
      break;
    }
  }
}
