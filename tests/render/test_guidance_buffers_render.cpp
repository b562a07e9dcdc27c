// Guidance buffers rendered on the GPU (engine/render/buffers/): a hand-built
// wall world with hand-computed depth / palette / instance / sky values, the
// per-frame dynamic-car overlay against a world rebuilt from scratch, an
// empty world, the Stage-2 writer on a procedural demo world along the demo
// ego drive, and the real Waymo scenario (skipped without data).
// CPU parts: test_guidance_buffers.cpp.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "test_world_util.h"
#include "test_stb_image.h"

#include "render/buffers/contact_sheet.h"
#include "render/buffers/coordinate_buffer.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/guidance_sequence.h"
#include "render/buffers/instance_colors.h"
#include "render/buffers/overlay_world.h"
#include "render/buffers/stage2_writer.h"
#include "render/buffers/tar_archive.h"
#include "render/buffers/trajectory.h"
#include "scene/atomic_file.h"
#include "scene/frames.h"
#include "scene/scene_load.h"
#include "video/codec_error.h"
#include "video/mp4_reader.h"
#include "world/car_mesh.h"
#include "world/demo_scene.h"
#include "world/npy.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <set>

using namespace icube;
using render::Rgb8;

namespace {

constexpr uint8_t kBuilding = 14, kRoad = 18, kCar = 1;

std::string temp_dir(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("icube-gb-" + name + "-" + std::to_string(getpid()));
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

Rgb8 rgb_at(const std::vector<uint8_t>& img, size_t i) { return {img[3 * i], img[3 * i + 1], img[3 * i + 2]}; }

render::Trajectory fixed_trajectory(const std::vector<glm::dmat4>& poses, const std::vector<int>& times) {
  render::Trajectory t;
  for (size_t i = 0; i < poses.size(); ++i) {
    t.c2w.push_back(poses[i]);
    t.frame_index.push_back(static_cast<int>(i));
    t.time_index.push_back(times[i]);
  }
  return t;
}

// A camera `height` metres above (x, y, 0) looking straight down (OpenCV: z = -world z, x = world x, y = -world y).
glm::dmat4 looking_down(double x, double y, double height) {
  glm::dmat4 m(1.0);
  m[0] = {1, 0, 0, 0};
  m[1] = {0, -1, 0, 0};
  m[2] = {0, 0, -1, 0};
  m[3] = {x, y, height, 1};
  return m;
}

}  // namespace

TEST_CASE("guidance buffers: a hand-built wall gives exact depth, palette, instance and sky values") {
  // Grid origin z = 0.055, so the wall's near face (voxel k = 50) is at z = 10.055 m exactly:
  // every pixel that hits has z-depth 10.055 m (a plane facing the camera), 1005 cm.
  world::VoxelGrid g({0.0, 0.0, 0.055});
  for (int i = -10; i < 20; ++i)      // x in [-2.0, 4.0)
    for (int j = -40; j < 40; ++j) {  // y in [-8, 8)
      const bool car = i >= 10;       // x >= 2.0: a car with instance 7
      g.set({i, j, 50}, car ? kCar : kBuilding, car ? 7 : 0);
      g.set({i, j, 51}, car ? kCar : kBuilding, car ? 7 : 0);
    }
  // fx = 10, cx = 8: column u hits x = 1.0055 (u - 8) -> u = 7..11 (u = 6: -2.011, u = 12: 4.022 miss);
  // columns 10, 11 (x = 2.011, 3.0165) are the car.
  render::PinholeIntrinsics K{10, 10, 8, 6, 16, 12};
  render::OverlayWorld ow(test::gpu_context(), g);
  const render::Trajectory traj = fixed_trajectory({glm::dmat4(1.0)}, {-1});
  render::SequenceOptions so;
  so.seed = 9;
  const render::GuidanceSequence seq = render::render_sequence(test::gpu_context(), ow, nullptr,
                                                               world::builtin_car_mesh(), K, traj, so);
  REQUIRE(seq.frames.size() == 1);
  const render::GuidanceFrame& f = seq.frames[0];
  const std::vector<uint16_t> cm = render::depth_centimetres(f.zdepth);
  const std::vector<uint8_t> sem = render::semantic_rgb(f, seq.instance_colors);
  REQUIRE(seq.instance_colors.count(7) == 1);
  std::mt19937_64 rng(9);
  const double u7 = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  const Rgb8 car_colour = render::purd_lut()[static_cast<size_t>(u7 * 256.0)];
  CHECK(seq.instance_colors.at(7) == car_colour);
  const std::vector<float> pts = render::coordinate_points(K, f.zdepth, seq.rel[0], seq.pixels);
  const std::vector<uint8_t> crd = render::encode_coordinates(pts, f.zdepth, seq.coordinates);
  for (uint32_t v = 0; v < K.height; ++v)
    for (uint32_t u = 0; u < K.width; ++u) {
      const size_t i = v * K.width + u;
      const bool hit = u >= 7 && u <= 11, car = u >= 10 && u <= 11;
      INFO("pixel (" << u << ", " << v << ")");
      CHECK(cm[i] == (hit ? 1005 : 0));
      CHECK(f.classes[i] == (hit ? (car ? kCar : kBuilding) : 0));
      CHECK(f.instance[i] == (car ? 7 : 0));
      const Rgb8 want = !hit ? Rgb8{31, 120, 180} : car ? car_colour : Rgb8{229, 196, 148};
      CHECK(rgb_at(sem, i) == want);
      if (!hit) CHECK(rgb_at(crd, i) == Rgb8{255, 255, 255});
      if (hit) CHECK(pts[3 * i] == doctest::Approx(10.055 * (static_cast<double>(u) - 8.0) / 10.0).epsilon(1e-5));
    }
  // x over the 60 hit points: {-1.0055, 0, 1.0055, 2.011, 3.0165} x 12; 5 % -> -1.0055, 95 % -> 3.0165.
  CHECK(seq.coordinates.samples == 60);
  CHECK(seq.coordinates.min.x == doctest::Approx(-1.0055).epsilon(1e-5));
  CHECK(seq.coordinates.range.x == doctest::Approx(4.022).epsilon(1e-5));
  CHECK(crd[3 * (6 * 16 + 9)] == 127);  // x = 1.0055: exactly mid-range
  // Depth .npy-level value and PNG-level value agree.
  CHECK(f.zdepth[6 * 16 + 8] == doctest::Approx(10.055).epsilon(1e-6));
}

TEST_CASE("guidance buffers: dynamic cars are overlaid per frame, the static world stays untouched") {
  // Static world: a 40 x 40 m road sheet at z in [0, 0.2), one parked car's old voxels (to be deleted).
  world::VoxelGrid src({0.0, 0.0, 0.0});
  for (int i = -100; i < 100; ++i)
    for (int j = -100; j < 100; ++j) src.set({i, j, 0}, kRoad);
  src.set({50, 50, 5}, kCar, 3);  // a vehicle voxel of the stage-1 world: removed
  scene::Scene s;
  s.timestamps = {0.0, 0.1, 0.2};
  auto box = [](double x, double y) {
    scene::BoxState b;
    b.center = {x, y, 0.2 + 0.75};
    b.length = 4.5;
    b.width = 1.8;
    b.height = 1.5;
    b.valid = true;
    return b;
  };
  scene::Track parked;
  parked.id = 5;
  parked.type = scene::ObjectType::Vehicle;
  parked.states = {box(-8, 6), box(-8, 6), box(-8, 6)};
  parked.instance_id = 1;
  scene::Track mover = parked;
  mover.id = 9;
  mover.dynamic = true;
  mover.instance_id = 10000;
  mover.states = {box(0, 0), box(5, 0), scene::BoxState{}};  // not observed in frame 2
  s.tracks = {parked, mover};
  const world::TriangleMesh mesh = world::builtin_car_mesh();
  render::StaticSceneStats st;
  const world::VoxelGrid stat = render::make_static_world(src, s, 0, mesh, &st);
  CHECK(st.vehicle_voxels_removed == 1);
  CHECK(st.static_cars == 1);
  CHECK(!stat.contains({50, 50, 5}));
  CHECK(st.car_cells > 100);
  // Every other voxel is kept unless a car cell took it (the wheels' lowest sub-voxels reach the sheet).
  size_t kept = 0, taken = 0;
  src.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    if (v.class_id == kCar) return;
    const world::Voxel now = stat.get(ijk);
    kept += now.class_id == v.class_id;
    taken += now.class_id == kCar && now.instance == 1;
  });
  CHECK(kept + taken == src.voxel_count() - 1);
  CHECK(taken < 100);
  CHECK(stat.class_histogram()[kCar] == st.car_cells);

  render::PinholeIntrinsics K{80, 80, 64, 48, 128, 96};  // 45 m across at 28 m
  const glm::dmat4 cam = looking_down(0, 0, 30);
  render::OverlayWorld ow(test::gpu_context(), stat, 1);  // capacity 1: forces a grow
  const render::Trajectory traj = fixed_trajectory({cam, cam, cam, cam}, {0, 1, 2, 0});
  render::SequenceOptions so;
  const render::GuidanceSequence seq = render::render_sequence(test::gpu_context(), ow, &s, mesh, K, traj, so);
  REQUIRE(seq.frames.size() == 4);
  auto centroid_u = [&](const render::GuidanceFrame& f, uint16_t id, size_t* count) {
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i < f.instance.size(); ++i)
      if (f.instance[i] == id) {
        sum += static_cast<double>(i % K.width);
        ++n;
      }
    *count = n;
    return n ? sum / static_cast<double>(n) : -1.0;
  };
  size_t n0 = 0, n1 = 0, n2 = 0, p0 = 0, p2 = 0;
  const double u0 = centroid_u(seq.frames[0], 10000, &n0);
  const double u1 = centroid_u(seq.frames[1], 10000, &n1);
  const double u2 = centroid_u(seq.frames[2], 10000, &n2);
  centroid_u(seq.frames[0], 1, &p0);
  centroid_u(seq.frames[2], 1, &p2);
  // A 4.5 x 1.8 m car ~28.3 m away at 80 px/unit: ~12.7 x 5 px.
  CHECK(n0 > 40);
  CHECK(n1 > 40);
  // Not observed in frame 2: drawn at its last state (frame 1), as InfiniCube distributes object info.
  CHECK(n2 == n1);
  CHECK(u2 == u1);
  CHECK(seq.frames[2].instance == seq.frames[1].instance);
  CHECK(p0 > 40);
  CHECK(p2 == p0);  // the parked car is in every frame
  // 5 m along +x at 30 m: the car's top (~1.7 m) is ~28.3 m away: ~ 5 · 80 / 28.3 = 14 px.
  CHECK(u1 - u0 == doctest::Approx(5.0 * 80.0 / 28.3).epsilon(0.15));
  // Frame 3 returns to state 0: identical to frame 0.
  CHECK(seq.frames[3].instance == seq.frames[0].instance);
  CHECK(seq.frames[3].zdepth == seq.frames[0].zdepth);

  // The overlay equals a world rebuilt from scratch with the same cells (car cells win, static cars kept).
  const std::vector<render::CarCell> cells = render::dynamic_car_cells(s, 1, mesh, stat.origin(), stat.voxel_size());
  render::CarVoxelCache cache;
  for (int rep = 0; rep < 2; ++rep)  // computed, then from the cache
    CHECK(render::dynamic_car_cells(s, 1, mesh, stat.origin(), stat.voxel_size(), nullptr, &cache) == cells);
  CHECK(cache.boxes.size() == 1);
  world::VoxelGrid full = stat;
  for (const auto& c : cells) {
    const world::Voxel old = full.get(c.ijk);
    if (old.class_id == kCar && old.instance > 0) continue;
    full.set(c.ijk, kCar, c.instance);
  }
  render::RaycasterGpu caster(test::gpu_context());
  render::Camera c;
  c.K = K;
  c.c2w = looking_down(2, 1, 12);
  render::RaycastOptions ro;
  ow.set_overlay(cells);
  const auto got = caster.cast_camera(ow.world(), c, ro);
  const render::RaycastWorld rebuilt = render::upload_raycast_world(test::gpu_context(), full);
  const auto want = caster.cast_camera(rebuilt, c, ro);
  REQUIRE(got.size() == want.size());
  size_t diff = 0;
  for (size_t i = 0; i < got.size(); ++i)
    diff += got[i].flags != want[i].flags || got[i].sem_class != want[i].sem_class ||
            got[i].sem_instance != want[i].sem_instance || got[i].t_depth != want[i].t_depth;
  CHECK(diff == 0);
  // Clearing the overlay restores the static world exactly.
  ow.set_overlay({});
  const render::RaycastWorld plain = render::upload_raycast_world(test::gpu_context(), stat);
  const auto a = caster.cast_camera(ow.world(), c, ro), b = caster.cast_camera(plain, c, ro);
  diff = 0;
  for (size_t i = 0; i < a.size(); ++i)
    diff += a[i].flags != b[i].flags || a[i].sem_instance != b[i].sem_instance || a[i].t_depth != b[i].t_depth;
  CHECK(diff == 0);
}


TEST_CASE("guidance buffers: a procedural demo world along the demo ego drive, written in the Stage-2 layout") {
  const scene::Scene s = world::make_demo_scene();
  const world::ProceduralPrior prior(s);
  const test::FirstChunks gen(prior, 2);
  world::WorldBuildOptions bo;
  bo.threads = 2;
  const world::WorldBuildResult built = world::build_world(s, gen, bo);
  const world::TriangleMesh mesh = world::builtin_car_mesh();
  const world::VoxelGrid stat = render::make_static_world(built.world, s, 0, mesh);
  REQUIRE(!s.cameras.empty());
  scene::Camera cam = scene::rescale_camera(s.cameras[0], 104, 60);
  render::Trajectory traj = render::select_frames(render::ego_trajectory(s, cam), render::parse_frame_range("0:30"));
  // Every 10th frame, so the dynamic cars move between frames.
  render::Trajectory sub;
  for (size_t i = 0; i < traj.size(); i += 10) {
    sub.c2w.push_back(traj.c2w[i]);
    sub.frame_index.push_back(traj.frame_index[i]);
    sub.time_index.push_back(traj.time_index[i]);
  }
  render::OverlayWorld ow(test::gpu_context(), stat);
  render::SequenceOptions so;
  so.seed = 3;
  so.keep_normals = true;
  size_t progress_calls = 0;
  so.progress = [&](size_t, size_t) { ++progress_calls; };
  const render::PinholeIntrinsics K = render::intrinsics_of(cam);
  const render::GuidanceSequence seq = render::render_sequence(test::gpu_context(), ow, &s, mesh, K, sub, so);
  CHECK(progress_calls == 3);
  REQUIRE(seq.frames.size() == 3);
  // Something is seen: road below the horizon, sky above it.
  size_t road = 0, sky = 0;
  for (uint8_t c : seq.frames[0].classes) {
    road += c == kRoad;
    sky += c == 0;
  }
  CHECK(road > 104 * 10);
  CHECK(sky > 104 * 5);
  // Semantic colours: palette entries or instance colours only.
  std::set<Rgb8> allowed(world::kGuidancePalette.begin(), world::kGuidancePalette.end());
  for (const auto& [id, c] : seq.instance_colors) allowed.insert(c);
  for (const auto& f : seq.frames) {
    const std::vector<uint8_t> rgb = render::semantic_rgb(f, seq.instance_colors);
    size_t bad = 0;
    for (size_t i = 0; i < f.classes.size(); ++i) bad += allowed.count(rgb_at(rgb, i)) == 0;
    CHECK(bad == 0);
  }

  {
    // Cost of one frame's overlay vs rebuilding and re-uploading the whole world with the same cars.
    using Clock = std::chrono::steady_clock;
    const auto cells = render::dynamic_car_cells(s, sub.time_index[1], mesh, stat.origin(), stat.voxel_size());
    auto t0 = Clock::now();
    const render::OverlayStats os = ow.set_overlay(cells);
    const double overlay_s = std::chrono::duration<double>(Clock::now() - t0).count();
    t0 = Clock::now();
    world::VoxelGrid full = stat;
    for (const auto& c : cells) full.set(c.ijk, kCar, c.instance);
    const render::RaycastWorld rebuilt = render::upload_raycast_world(test::gpu_context(), full);
    const double full_s = std::chrono::duration<double>(Clock::now() - t0).count();
    CHECK(os.bricks > 0);
    CHECK(os.uploaded_bytes < static_cast<size_t>(rebuilt.gpu.brick_data.size() + rebuilt.gpu.brick_table.size()));
    MESSAGE("overlay: " << os.cells << " cells in " << os.bricks << " bricks (" << os.new_bricks << " new), "
                        << os.uploaded_bytes / 1024 << " KiB, " << overlay_s * 1e3 << " ms; full rebuild of "
                        << stat.brick_count() << " bricks: " << full_s * 1e3 << " ms");
  }
  const std::string dir = temp_dir("stage2");
  const glm::dmat4 w2v = render::world_to_voxel_world(sub.c2w[0]);
  render::Stage2Options wo;
  wo.clip = "demo";
  wo.normals = true;  // videos on, with upstream's encoder settings
  const render::Stage2Result wr = render::write_stage2(seq, &s, w2v, dir, wo);
  CHECK(wr.files > 10);
  CHECK(wr.notes.empty());
  // Frames are numbered 0..N-1 as written (trajectory frames 0, 10, 20), as upstream's readers look them up.
  const auto depth = render::parse_tar(scene::read_file(dir + "/voxel_depth_100_480p_front.tar"));
  REQUIRE(depth.size() == 3);
  CHECK(depth[0].name == "demo.000000.voxel_depth_100.front.png");
  CHECK(depth[1].name == "demo.000001.voxel_depth_100.front.png");
  const auto inst = render::parse_tar(scene::read_file(dir + "/instance_buffer_480p_front.tar"));
  CHECK(inst[2].name == "demo.000002.instance_buffer.front.png");
  const nlohmann::json meta = nlohmann::json::parse(scene::read_file(dir + "/buffers_meta.json"));
  CHECK(meta["source_frame_indices"] == nlohmann::json::array({0, 10, 20}));
  CHECK(meta["source_time_indices"] == nlohmann::json::array({sub.time_index[0], sub.time_index[1], sub.time_index[2]}));
  CHECK(meta["object_info"] == "moving");
  const auto poses = render::parse_tar(scene::read_file(dir + "/pose.tar"));
  REQUIRE(poses.size() == 3);
  CHECK(poses[1].name == "demo.000001.pose.front.npy");
  // Pose 0 in the voxel world is flu_to_opencv(identity) = the FLU->OpenCV axis permutation; float32 as upstream.
  const world::NpyArray p0 = world::npy_from_bytes(poses[0].data, "pose0");
  CHECK(p0.shape == std::vector<uint64_t>{4, 4});
  CHECK(p0.dtype == world::NpyDtype::F4);
  const glm::dmat4 want0 = scene::flu_to_opencv(glm::dmat4(1.0));
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) CHECK(p0.as_double(static_cast<size_t>(4 * r + c)) == doctest::Approx(want0[c][r]));
  const world::NpyArray p2 = world::npy_from_bytes(poses[2].data, "pose2");
  const glm::dmat4 want2 = w2v * sub.c2w[2];
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      CHECK(p2.values<float>()[static_cast<size_t>(4 * r + c)] == static_cast<float>(want2[c][r]));
  const auto intr = render::parse_tar(scene::read_file(dir + "/intrinsic.tar"));
  REQUIRE(intr.size() == 1);
  CHECK(intr[0].name == "demo.intrinsic.front.npy");
  const world::NpyArray k = world::npy_from_bytes(intr[0].data, "intrinsic");
  CHECK(k.as_double(0) == doctest::Approx(K.fx));
  CHECK(k.as_double(4) == 104.0);
  CHECK(k.as_double(5) == 60.0);
  // dynamic_object_info: upstream's content, the ever-moving cars only, ids from 10000, each in every frame.
  std::set<std::string> moving_gids;
  uint32_t lowest_dynamic = 0xFFFFFFFFu;
  for (size_t i = 0; i < s.tracks.size(); ++i)
    if (s.tracks[i].type == scene::ObjectType::Vehicle && s.tracks[i].dynamic && !scene::is_ego_track(s, i)) {
      moving_gids.insert(std::to_string(s.tracks[i].id));
      lowest_dynamic = std::min(lowest_dynamic, s.tracks[i].instance_id);
    }
  REQUIRE(!moving_gids.empty());
  CHECK(lowest_dynamic == scene::kFirstDynamicInstanceId);
  const auto objs = render::parse_tar(scene::read_file(dir + "/dynamic_object_info.tar"));
  REQUIRE(objs.size() == 3);
  CHECK(objs[1].name == "demo.000001.dynamic_object_info.json");
  for (const auto& member : objs) {
    const nlohmann::json j = nlohmann::json::parse(member.data);
    std::set<std::string> gids;
    for (const auto& [gid, o] : j.items()) {
      gids.insert(gid);
      CHECK(o["object_type"] == "car");
      CHECK(o["object_to_world"].size() == 4);
      CHECK(o["object_lwh"].size() == 3);
      CHECK(o["object_id_int"].get<uint32_t>() >= scene::kFirstDynamicInstanceId);
    }
    CHECK(gids == moving_gids);
  }
  // The documented alternative: every vehicle where observed, parked cars (ids from 1) included.
  const nlohmann::json observed =
      nlohmann::json::parse(render::dynamic_object_info_json(&s, sub.time_index[1], w2v, render::ObjectInfoMode::Observed));
  size_t parked = 0;
  for (const auto& [gid, o] : observed.items()) parked += o["object_id_int"].get<uint32_t>() < scene::kFirstDynamicInstanceId;
  CHECK(parked == 10);
  // The mp4s: every frame, and the decoded semantic and coordinate frames match their PNGs within the codec's error.
  for (const char* name : {"semantic_buffer", "coordinate_buffer"}) {
    CAPTURE(name);
    const video::DecodedVideo dv = video::read_video(dir + "/" + name + "_video_480p_front.mp4");
    REQUIRE(dv.frames.size() == 3);
    CHECK(dv.width == 104);
    CHECK(dv.height == 60);
    CHECK(dv.fps == doctest::Approx(10.0));
    for (size_t f = 0; f < 3; ++f) {
      int pw = 0, ph = 0, pc = 0;
      const std::string png = dir + "/" + name + "/" + std::string(6 - 1, '0') + std::to_string(f) + ".png";
      unsigned char* px = stbi_load(png.c_str(), &pw, &ph, &pc, 3);
      REQUIRE(px != nullptr);
      const std::vector<uint8_t> png_rgb(px, px + size_t{104} * 60 * 3);
      stbi_image_free(px);
      const test::CodecError e = test::codec_error(png_rgb, 104, 60, dv.frames[f], dv.width);
      MESSAGE(std::string(name) << " frame " << f << ": mean |mp4 - png| " << e.mean_abs << " levels, PSNR "
                                << e.psnr_db << " dB, bias " << e.worst_bias() << ", flat interiors within " << test::kInteriorLevels
                                << " levels: " << e.interior_within);
      // 104x60 frames are mostly edges (4:2:0 chroma mixes the colours across them; crf 23.5):
      // measured mean 3.7-6.9 levels, PSNR 24.6-28.7 dB, bias <= 1.3, interiors 0.97-1.0 within 8 levels.
      CHECK(e.mean_abs < 9.0);
      CHECK(e.psnr_db > 22.0);
      CHECK(e.worst_bias() < 2.5);
      CHECK(e.interior_within > 0.95);
    }
  }
  CHECK(video::read_video(dir + "/depth_vis_video_480p_front.mp4").frames.size() == 3);
  // The depth PNG in the tar decodes to the frame's centimetres.
  int w = 0, h = 0, ch = 0;
  stbi_us* px = stbi_load_16_from_memory(reinterpret_cast<const stbi_uc*>(depth[0].data.data()),
                                          static_cast<int>(depth[0].data.size()), &w, &h, &ch, 1);
  REQUIRE(px != nullptr);
  CHECK(w == 104);
  CHECK(h == 60);
  const std::vector<uint16_t> cm = render::depth_centimetres(seq.frames[0].zdepth);
  CHECK(std::memcmp(px, cm.data(), cm.size() * 2) == 0);
  stbi_image_free(px);
  const world::NpyArray dnpy = world::read_npy(dir + "/depth/000001.npy");
  CHECK(dnpy.shape == std::vector<uint64_t>{60, 104});
  CHECK(dnpy.values<float>() == seq.frames[1].zdepth);
  CHECK(std::filesystem::exists(dir + "/coordinate_buffer/000002.png"));
  CHECK(std::filesystem::exists(dir + "/coordinate_points/000002.npy"));
  CHECK(!std::filesystem::exists(dir + "/coordinate_points/000020.npy"));
  CHECK(std::filesystem::exists(dir + "/normal_buffer/000000.png"));
  CHECK(std::filesystem::exists(dir + "/world_to_voxel_world.npy"));
  const scene::Canvas sheet = render::contact_sheet(seq, "demo");
  CHECK(sheet.width() > 3 * 104);
  render::write_contact_sheet(dir + "/contact_sheet.png", sheet);
  CHECK(std::filesystem::exists(dir + "/contact_sheet.png"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("guidance buffers: the real Waymo scenario renders along its ego track") {
  const std::string data = test::test_data_dir();
  if (data.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  const scene::Scene s = scene::load_scene(data + "/maps/waymo/motion_data_one_scenario.tfrecord");
  const world::ProceduralPrior prior(s);
  const test::FirstChunks gen(prior, 1);
  world::WorldBuildOptions bo;
  bo.threads = 2;
  const world::WorldBuildResult built = world::build_world(s, gen, bo);
  const world::TriangleMesh mesh = world::builtin_car_mesh();
  const world::VoxelGrid stat = render::make_static_world(built.world, s, 0, mesh);
  const scene::Camera cam = scene::rescale_camera(s.cameras.empty() ? scene::waymo_front_camera() : s.cameras[0], 104, 60);
  render::Trajectory traj = render::select_frames(render::ego_trajectory(s, cam), render::parse_frame_range("0:2"));
  render::OverlayWorld ow(test::gpu_context(), stat);
  const render::GuidanceSequence seq =
      render::render_sequence(test::gpu_context(), ow, &s, mesh, render::intrinsics_of(cam), traj, {});
  REQUIRE(seq.frames.size() == 2);
  size_t hits = 0;
  for (float z : seq.frames[0].zdepth) hits += z > 0.0f;
  CHECK(hits > 104 * 60 / 4);
  CHECK(seq.coordinates.samples == hits + [&] {
    size_t n = 0;
    for (float z : seq.frames[1].zdepth) n += z > 0.0f;
    return n;
  }());
}

TEST_CASE("guidance buffers: an empty world is sky everywhere, then a car-only overlay appears") {
  const world::VoxelGrid empty;
  render::OverlayWorld ow(test::gpu_context(), empty);
  render::PinholeIntrinsics K{8, 8, 4, 3, 8, 6};
  const render::GuidanceSequence seq = render::render_sequence(
      test::gpu_context(), ow, nullptr, world::builtin_car_mesh(), K, fixed_trajectory({glm::dmat4(1.0)}, {-1}), {});
  const render::GuidanceFrame& f = seq.frames[0];
  const std::vector<uint8_t> sem = render::semantic_rgb(f, seq.instance_colors);
  for (size_t i = 0; i < f.zdepth.size(); ++i) {
    CHECK(f.zdepth[i] == 0.0f);
    CHECK(rgb_at(sem, i) == Rgb8{31, 120, 180});
  }
  CHECK(seq.coordinates.samples == 0);
  CHECK(seq.coordinates.range == glm::dvec3(render::kCoordinateMinRange));
  // One car cell straight ahead at z = 5 m.
  ow.set_overlay({{{0, 0, 25}, 10000}});
  render::RaycasterGpu caster(test::gpu_context());
  render::Camera c;
  c.K = K;
  c.c2w = glm::translate(glm::dmat4(1.0), glm::dvec3(0.1, 0.1, 0.0));  // through the cell's centre column
  const auto hits = caster.cast_camera(ow.world(), c, {});
  const shader::RaycastHit& h = hits[3 * 8 + 4];  // the principal ray
  CHECK(h.sem_class == kCar);
  CHECK(h.sem_instance == 10000);
  CHECK(h.t_depth == doctest::Approx(5.0));
}
