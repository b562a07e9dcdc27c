// Stage 3 with the learned GSM (engine/lift/gsm_lift.h, gsm_lift_inputs.h,
// gsm_gaussians.h): the model's integer-pixel intrinsics after a resize, the
// grid frame and its voxel crop, the Gaussians in the package's conventions
// (through the .ply and back; into an object's box frame and placed back),
// the official per-object choice of key frame, the sky image against the
// sky model in the renderer's directions, the size checks; and `icube lift
// --gsm` on the demo town with random weights of gsm_small's structure (its
// pixel branch's depth pinned to a car's depth, so the dynamic pass finds
// it): the package's files, the Gaussian counts the model's structure gives,
// the mid-ground pixels of the last key frame only, the car's Gaussians inside
// its box; bad weights, configs and sizes refused with nothing written.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gpu_test_context.h"
#include "lift_demo_frames.h"
#include "lift/dynamic_lift.h"
#include "lift/gsm_depth_support.h"
#include "lift/gsm_gaussians.h"
#include "lift/gsm_lift.h"
#include "lift/gsm_lift_inputs.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_random_weights.h"
#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/sky_reference.h"
#include "nn/safetensors.h"
#include "render/buffers/frame_scene.h"
#include "scene/atomic_file.h"
#include "scene/frames.h"
#include "scene/png_read.h"
#include "scene/scene_load.h"
#include "splat/splat_scene.h"
#include "world/car_mesh.h"
#include "world/world_file.h"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <random>

using namespace icube;
namespace fs = std::filesystem;

namespace {

// The ray of model pixel (u, v) through intrinsics k, camera frame.
glm::dvec3 model_ray(const std::array<float, 6>& k, double u, double v) {
  return glm::normalize(glm::dvec3((u - double(k[2])) / double(k[0]), (v - double(k[3])) / double(k[1]), 1.0));
}

nn::CpuTensor random_tensor(std::vector<int64_t> shape, std::mt19937& rng, float lo, float hi) {
  nn::CpuTensor t(std::move(shape));
  std::uniform_real_distribution<float> d(lo, hi);
  for (float& x : t.data) x = d(rng);
  return t;
}

}  // namespace

TEST_CASE("gsm lift: the model's intrinsics give each resized pixel the ray of the place it samples") {
  render::PinholeIntrinsics K;
  K.fx = 180.0, K.fy = 170.0, K.cx = 104.0, K.cy = 60.0, K.width = 208, K.height = 120;
  for (const auto pixels : {render::PixelConvention::Integer, render::PixelConvention::Centre}) {
    const double o = pixels == render::PixelConvention::Centre ? 0.5 : 0.0;
    // Same size: the model's integer pixel u is the folder's pixel u.
    const std::array<float, 6> same = lift::gsm_intrinsics(K, pixels, 208, 120);
    CHECK(same[4] == 208.0f);
    CHECK(same[5] == 120.0f);
    const glm::dvec3 want0 = glm::normalize(glm::dvec3((17.0 + o - K.cx) / K.fx, (33.0 + o - K.cy) / K.fy, 1.0));
    CHECK(glm::length(model_ray(same, 17.0, 33.0) - want0) < 1e-6);
    // 208 x 120 -> 104 x 48: resized pixel u' samples the folder's continuous index (u' + 0.5) / s - 0.5.
    const std::array<float, 6> half = lift::gsm_intrinsics(K, pixels, 104, 48);
    for (const glm::dvec2 uv : {glm::dvec2(0, 0), glm::dvec2(51, 20), glm::dvec2(103, 47)}) {
      const double su = (uv.x + 0.5) / (104.0 / 208.0) - 0.5, sv = (uv.y + 0.5) / (48.0 / 120.0) - 0.5;
      const glm::dvec3 want = glm::normalize(glm::dvec3((su + o - K.cx) / K.fx, (sv + o - K.cy) / K.fy, 1.0));
      CAPTURE(uv.x);
      CHECK(glm::length(model_ray(half, uv.x, uv.y) - want) < 1e-6);
    }
  }
}

TEST_CASE("gsm lift: the grid frame keeps the world's 0.2 m lattice; the crop keeps voxels near the key cameras") {
  world::VoxelGrid w(glm::dvec3(10.3, -4.1, 0.7), 0.2);
  for (int x = 0; x < 100; ++x) w.set({x, 3, 0}, 18, 0);
  const glm::dvec3 cam(10.3 + 0.2 * 20.5, -4.1 + 0.2 * 3.5, 2.0);
  const lift::GsmGridFrame g = lift::gsm_grid_frame(w, cam, "w.icw");
  CHECK(g.anchor == glm::ivec3(20, 3, 6));
  // World voxel ijk is grid voxel ijk - anchor, centred at 0.2 (ijk - anchor) + 0.1 in the grid frame.
  const glm::dvec3 centre = w.ijk_to_world({57, 3, 0});
  const glm::dvec3 grid_centre = glm::dvec3(glm::inverse(g.grid_to_world()) * glm::dvec4(centre, 1.0));
  CHECK(glm::length(grid_centre - (glm::dvec3(57 - 20, 0, -6) * 0.2 + 0.1)) < 1e-9);
  // Within 2.05 m in x, y of the camera: voxels x with |x + 0.5 - 20.5| * 0.2 <= 2.05, x = 10 ... 30.
  const std::vector<nn::Ijk> near = lift::gsm_crop_voxels(w, g, {cam}, 2.05);
  REQUIRE(near.size() == 21);
  CHECK(near.front() == nn::Ijk{10 - 20, 0, -6});
  CHECK(near.back() == nn::Ijk{30 - 20, 0, -6});
  CHECK(lift::gsm_crop_voxels(w, g, {cam}, 0.0).size() == 100);
  // The pose: rotation as given, translation into the grid frame.
  glm::dmat4 c2w = glm::rotate(glm::dmat4(1.0), 0.3, glm::dvec3(0, 0, 1));
  c2w[3] = glm::dvec4(cam, 1.0);
  const std::array<float, 16> p = lift::gsm_pose(c2w, g);
  CHECK(p[0] == float(c2w[0][0]));
  CHECK(p[1] == float(c2w[1][0]));
  CHECK(std::fabs(double(p[3]) - (cam.x - g.offset.x)) < 1e-6);
  CHECK(std::fabs(double(p[11]) - (cam.z - g.offset.z)) < 1e-6);
  CHECK_THROWS_WITH_AS(lift::gsm_grid_frame(world::VoxelGrid(glm::dvec3(0.0), 0.1), cam, "fine.icw"),
                       "fine.icw: the GSM takes 0.2 m voxels; this world's are 0.100000 m", scene::InputError);
}

TEST_CASE("gsm lift: the depth prior's support gives every pixel the voxel depth of the whole grid") {
  // A ground slab, solid blocks, and scattered single voxels (corner clips and short runs) in front of a
  // camera looking along +x, slightly down and yawed.
  std::mt19937 rng(3);
  std::vector<nn::Ijk> ijk;
  for (int x = -20; x < 200; ++x)
    for (int y = -60; y < 60; ++y) {
      ijk.push_back({x, y, -12});
      if ((x / 10 + y / 10) % 3 == 0 && x > 20 && std::abs(y) > 15)
        for (int z = -11; z < -11 + (x % 7) * 3; ++z) ijk.push_back({x, y, z});
    }
  std::uniform_int_distribution<int> ux(0, 150), uy(-40, 40), uz(-11, 10);
  for (int i = 0; i < 4000; ++i) ijk.push_back({ux(rng), uy(rng), uz(rng)});
  std::sort(ijk.begin(), ijk.end());
  ijk.erase(std::unique(ijk.begin(), ijk.end()), ijk.end());
  nn::GsmInputs in;
  in.batch = 1, in.views = 1, in.width = 64, in.height = 48;
  in.voxel_ijk = {ijk};
  in.intrinsics = {{40.0f, 40.0f, 31.5f, 20.0f, 64.0f, 48.0f}};
  // OpenCV camera (x right, y down, z forward) looking along grid +x, yawed 0.2 rad, pitched down 0.1 rad.
  const glm::dmat3 R = glm::dmat3(glm::rotate(glm::dmat4(1.0), 0.2, glm::dvec3(0, 0, 1))) *
                       glm::dmat3(glm::rotate(glm::dmat4(1.0), 0.1, glm::dvec3(0, 1, 0))) *
                       glm::dmat3(glm::dvec3(0, -1, 0), glm::dvec3(0, 0, -1), glm::dvec3(1, 0, 0));
  std::array<float, 16> pose{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) pose[size_t(4 * r + c)] = float(R[c][r]);
  pose[3] = 0.13f, pose[7] = 0.07f, pose[11] = -0.9f, pose[15] = 1.0f;
  in.poses = {pose};
  const std::vector<nn::Ijk> support = lift::gsm_depth_support(in, 0);
  nn::GsmInputs sub = in;
  sub.voxel_ijk = {support};
  const nn::GsmPixelRays full = nn::cast_gsm_pixel_rays(in, 0), part = nn::cast_gsm_pixel_rays(sub, 0);
  size_t with_depth = 0, differ = 0;
  for (size_t p = 0; p < full.voxel_depth.size(); ++p) {
    with_depth += full.voxel_depth[p] > 0.0f;
    differ += std::fabs(full.voxel_depth[p] - part.voxel_depth[p]) > 1e-5f * std::max(1.0f, full.voxel_depth[p]);
  }
  MESSAGE("support: " << support.size() << " of " << ijk.size() << " voxels; " << with_depth << " of "
                      << full.voxel_depth.size() << " pixels with a depth");
  CHECK(with_depth > 2000);
  CHECK(differ == 0);
  CHECK(support.size() * 10 < ijk.size());
  CHECK(std::is_sorted(support.begin(), support.end()));
}

TEST_CASE("gsm lift: the model's Gaussians in the package's conventions, through the .ply and into a box frame") {
  std::mt19937 rng(7);
  const int64_t n = 6;
  nn::CpuTensor means = random_tensor({n, 3}, rng, -3.0f, 3.0f), scales = random_tensor({n, 3}, rng, 0.01f, 0.5f);
  nn::CpuTensor rotations = random_tensor({n, 4}, rng, -1.0f, 1.0f), opacities = random_tensor({n, 1}, rng, 0.05f, 0.95f);
  nn::CpuTensor colors = random_tensor({n, 3}, rng, -0.2f, 1.2f);
  for (int64_t i = 0; i < n; ++i) {
    float* q = &rotations.data[size_t(4 * i)];
    const float norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int k = 0; k < 4; ++k) q[k] /= norm;
  }
  // Row 4: a zero quaternion (F.normalize leaves it zero) and an underflowed scale.
  for (int k = 0; k < 4; ++k) rotations.data[16 + size_t(k)] = 0.0f;
  scales.data[12] = 0.0f;
  const lift::GsmGaussianTensors t{&means, &scales, &rotations, &opacities, &colors};
  lift::GsmGridFrame g;
  g.offset = glm::dvec3(-137.6, -1.8, 2.0);
  splat::GaussianCloud cloud;
  lift::GsmConversionStats st;
  lift::append_gsm_gaussians(cloud, t, g.grid_to_world(), nullptr, &st);
  REQUIRE(cloud.size() == size_t(n));
  CHECK(st.identity_rotations == 1);
  CHECK(st.floored_scales == 1);
  // Through the .ply writer and reader: what the renderer and viewer get.
  const splat::GaussianCloud back = splat::gaussians_from_ply_bytes(splat::gaussians_to_ply_bytes(cloud), "gsm.ply");
  REQUIRE(back.size() == size_t(n));
  for (size_t i = 0; i < size_t(n); ++i) {
    CAPTURE(i);
    for (int a = 0; a < 3; ++a) {
      CHECK(std::fabs(back.positions[i][a] - (double(means.data[3 * i + size_t(a)]) + g.offset[a])) < 2e-5);
      const float s = i == 4 && a == 0 ? lift::kMinGsmScale : scales.data[3 * i + size_t(a)];
      CHECK(std::fabs(back.scales[i][a] - s) <= 1e-6f * s);
      // The renderer's colour 0.5 + C0 f_dc is the model's raw RGB.
      CHECK(std::fabs(0.5 + splat::kShC0 * double(back.sh[3 * i + size_t(a)]) - double(colors.data[3 * i + size_t(a)])) < 1e-6);
    }
    CHECK(std::fabs(back.opacities[i] - opacities.data[i]) < 1e-6f);
    for (int k = 0; k < 4; ++k) {
      const float want = i == 4 ? (k == 0 ? 1.0f : 0.0f) : rotations.data[4 * i + size_t(k)];
      CHECK(std::fabs(back.rotations[i][k] - want) < 1e-6f);
    }
  }
  // Rows 1, 3, 5 into a box frame (rotated and moved), placed back by the box's pose: the same
  // means and covariances (the renderer's rigid placement).
  glm::dmat4 object_to_grid = glm::rotate(glm::dmat4(1.0), 0.7, glm::normalize(glm::dvec3(0.1, 0.2, 1.0)));
  object_to_grid[3] = glm::dvec4(1.5, -0.5, 0.3, 1.0);
  const std::vector<size_t> rows = {1, 3, 5};
  splat::GaussianCloud obj;
  lift::append_gsm_gaussians(obj, t, glm::inverse(object_to_grid), &rows);
  REQUIRE(obj.size() == 3);
  for (size_t k = 0; k < rows.size(); ++k) {
    const size_t i = rows[k];
    const glm::dvec3 placed = glm::dvec3(object_to_grid * glm::dvec4(obj.positions[k], 1.0));
    for (int a = 0; a < 3; ++a) CHECK(std::fabs(placed[a] - double(means.data[3 * i + size_t(a)])) < 1e-5);
    const glm::dmat3 R(object_to_grid);
    const glm::dquat qo(obj.rotations[k].x, obj.rotations[k].y, obj.rotations[k].z, obj.rotations[k].w);
    const glm::dmat3 placed_rot = R * glm::mat3_cast(qo);
    const float* q = &rotations.data[4 * i];
    const glm::dmat3 want_rot = glm::mat3_cast(glm::dquat(q[0], q[1], q[2], q[3]));
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) CHECK(std::fabs(placed_rot[c][r] - want_rot[c][r]) < 1e-5);
  }
}

TEST_CASE("gsm lift: each object keeps the key frame with the most Gaussians inside its box, the first on ties") {
  // Frame 10: 3 Gaussians in box 10001 (2 m long, at x = 5), 1 in box 10002; frame 20: 2 and 2.
  auto frame = [](const std::vector<glm::dvec3>& pts) {
    nn::CpuTensor m({int64_t(pts.size()), 3}), s({int64_t(pts.size()), 3}, 0.1f), q({int64_t(pts.size()), 4}),
        o({int64_t(pts.size()), 1}, 0.5f), c({int64_t(pts.size()), 3}, 0.5f);
    for (size_t i = 0; i < pts.size(); ++i) {
      for (int a = 0; a < 3; ++a) m.data[3 * i + size_t(a)] = float(pts[i][a]);
      q.data[4 * i] = 1.0f;
    }
    return std::array<nn::CpuTensor, 5>{m, s, q, o, c};
  };
  glm::dmat4 box1(1.0), box2 = glm::rotate(glm::dmat4(1.0), glm::radians(90.0), glm::dvec3(0, 0, 1));
  box1[3] = glm::dvec4(5.0, 0.0, 0.75, 1.0);
  box2[3] = glm::dvec4(-4.0, 2.0, 0.75, 1.0);
  const std::vector<lift::GsmObjectBox> boxes = {{10001, box1, {2.0, 1.0, 1.5}}, {10002, box2, {4.0, 1.0, 1.5}}};
  // Box 2 is turned by 90 degrees: its 4 m length runs along y, so (-4, 3.8) is inside, (-5.8, 2) is not.
  const auto f10 = frame({{5.5, 0.2, 0.5}, {4.2, -0.4, 1.2}, {5.9, 0.1, 0.2}, {-4.2, 3.8, 1.0}, {-5.8, 2.0, 1.0}, {7.0, 0.0, 0.5}});
  const auto f20 = frame({{5.0, 0.0, 0.5}, {5.1, 0.0, 0.5}, {-4.0, 1.0, 1.0}, {-3.9, 0.5, 0.7}});
  const lift::GsmGaussianTensors t10{&f10[0], &f10[1], &f10[2], &f10[3], &f10[4]}, t20{&f20[0], &f20[1], &f20[2], &f20[3], &f20[4]};
  lift::GsmObjectPicker picker;
  picker.add_frame(10, t10, {0, 1, 2, 3, 4, 5}, boxes);
  picker.add_frame(20, t20, {0, 1, 2, 3}, boxes);
  REQUIRE(picker.picks().size() == 2);
  const auto& p1 = picker.picks().at(10001);
  CHECK(p1.frame == 10);
  CHECK(p1.rows == std::vector<size_t>{0, 1, 2});
  const auto& p2 = picker.picks().at(10002);
  CHECK(p2.frame == 20);  // 2 > 1
  CHECK(p2.rows == std::vector<size_t>{2, 3});
  // Only candidate rows count: frame 30 offers row 3 of frame 20's tensors alone.
  picker.add_frame(30, t20, {3}, boxes);
  CHECK(picker.picks().at(10002).frame == 20);
}

TEST_CASE("gsm lift: the sky image is the model's sky in the renderer's directions") {
  nn::SkyConfig c;
  c.embed_dim = 8;
  c.hidden_channels = 6;
  c.out_channels = 3;
  nn::GsmWeights w;
  std::mt19937 rng(11);
  auto linear = [&](const std::string& name, int64_t out, int64_t in, float scale) {
    w.tensors["skybox.modulator." + name + ".weight"] = random_tensor({out, in}, rng, -scale, scale);
    w.tensors["skybox.modulator." + name + ".bias"] = random_tensor({out}, rng, -0.3f, 0.3f);
  };
  linear("pos_emb", 6, 3, 1.0f);
  linear("adaLN_modulation.1", 12, 6, 0.4f);
  linear("condition_mapping", 6, 8, 0.4f);
  linear("output", 3, 6, 0.15f);
  w.tensors["skybox.modulator.output.bias"] = nn::CpuTensor({3}, std::vector<float>{0.5f, 0.55f, 0.6f});
  const nn::CpuTensor token = random_tensor({1, 8}, rng, -1.0f, 1.0f);
  const nn::CpuTensor pano = nn::sky_panorama(c, w, token, 128);
  const splat::SkyImage img = lift::gsm_sky_image(pano);
  REQUIRE(img.width == 256);
  REQUIRE(img.height == 128);
  CHECK(img.rgba[3] == 255);
  for (size_t p = 0; p < 10; ++p)
    CHECK(img.rgba[4 * p] == uint8_t(std::lround(std::clamp(double(pano.data[3 * p]), 0.0, 1.0) * 255.0)));
  // The renderer's colour for a world direction (the grid's axes are the world's) against the model's
  // (its directions in OpenGL axes: (x, y, z) -> (-y, z, -x)): within the 8-bit and bilinear error.
  const splat::SkyModel sky = splat::sky_equirect(std::make_shared<const splat::SkyImage>(img));
  std::uniform_real_distribution<double> ud(-1.0, 1.0);
  double worst = 0.0, spread = 0.0;
  for (int i = 0; i < 200; ++i) {
    glm::dvec3 d(ud(rng), ud(rng), ud(rng));
    if (glm::length(d) < 0.1) continue;
    d = glm::normalize(d);
    if (std::fabs(d.z) > 0.97) continue;  // the poles' rows are clamped
    const glm::vec3 got = splat::sky_color(sky, glm::vec3(0.0f), glm::vec3(d));
    const nn::CpuTensor want = nn::sky_colors(c, w, token.data.data(), nn::CpuTensor({1, 3}, {float(-d.y), float(d.z), float(-d.x)}));
    const nn::CpuTensor opposite = nn::sky_colors(c, w, token.data.data(), nn::CpuTensor({1, 3}, {float(d.y), float(d.z), float(d.x)}));
    for (int k = 0; k < 3; ++k) {
      const double v = std::clamp(double(want.data[size_t(k)]), 0.0, 1.0);
      worst = std::max(worst, std::fabs(double(got[k]) - v));
      spread = std::max(spread, std::fabs(v - std::clamp(double(opposite.data[size_t(k)]), 0.0, 1.0)));
    }
  }
  MESSAGE("sky image vs the model: max error " << worst << " (the model's colour range over mirrored directions " << spread << ")");
  CHECK(worst < 0.01);
  CHECK(spread > 0.05);  // the test can tell a mirrored convention
}

TEST_CASE("gsm lift: input sizes the model does not take and past the limits are refused by name") {
  nn::GsmConfig c;
  c.sky.patch_size = 16;
  c.pixel.depth_patch_size = 16;
  lift::GsmLiftOptions o;
  o.key_every = 6;
  const lift::GsmLiftPlan p = lift::gsm_lift_plan(20, 832, 480, "m.json", c, o);
  CHECK(p.key_frames == std::vector<size_t>{0, 6, 12, 18});
  CHECK(p.width == 832);
  CHECK(p.height == 480);
  CHECK_THROWS_WITH_AS(lift::gsm_lift_plan(8, 208, 120, "m.json", c, o),
                       "m.json: the GSM's input size 208x120 is not made of whole 16-pixel patches (its sky and depth "
                       "patches): give the model's input size (--gsm-size), e.g. 208x112 (the frames are resized to it)",
                       scene::InputError);
  o.width = 208, o.height = 112;
  CHECK(lift::gsm_lift_plan(8, 208, 120, "m.json", c, o).height == 112);
  o.width = 1920, o.height = 1088;
  CHECK_THROWS_WITH_AS(lift::gsm_lift_plan(8, 208, 120, "m.json", c, o),
                       "m.json: the GSM's input size 1920x1088 is 2088960 pixels per key frame, more than its limit of "
                       "524288 (one key frame's 64-channel feature maps must fit one storage binding of 128 MiB on this "
                       "device): give a smaller input size (--gsm-size; the official one is 832x480)",
                       scene::InputError);
  // A device with 4 GiB bindings (NVIDIA) takes it.
  o.max_view_pixels = lift::gsm_max_view_pixels(4ull << 30);
  CHECK(lift::gsm_lift_plan(8, 208, 120, "m.json", c, o).width == 1920);
  o.width = 208, o.height = 112;
  o.max_pixels = 208 * 112;
  CHECK_THROWS_WITH_AS(lift::gsm_lift_plan(8, 208, 120, "m.json", c, o),
                       "m.json: 2 key frames of 208x112 are 46592 pixels for the GSM, more than its limit of 23296: lift "
                       "from fewer key frames (a larger --key-every) or at a smaller input size (--gsm-size)",
                       scene::InputError);
}

TEST_CASE("cli: icube lift --gsm on the demo town: the package, the model's counts, a car in its box; bad models refused" *
          doctest::test_suite("slow-gpu")) {
  const std::string small_config = test::test_data_file("models/gsm_small/config.json");
  if (small_config.empty()) return;
  const test::LiftDemoFrames& demo = test::lift_demo_frames();
  test::TempDir dir("gsm-lift");
  const fs::path frames = demo.frames;
  const render::FramesMeta meta = render::read_frames_meta(frames.string());
  scene::Scene sc = scene::load_scene(demo.scene, scene::LoadOptions{}, nullptr);
  if (scene::tracks_unclassified(sc)) scene::classify_tracks(sc);

  // The key frames 0 and 6 (interval 6); a moving car seen in one of them, its camera-z depth.
  uint16_t car = 0;
  size_t car_frame = 0, car_pixels = 0;
  double depth = 0.0;
  for (const size_t f : {size_t(0), size_t(6)}) {
    int w = 0, h = 0;
    const std::string name = (frames / "instance" / render::frame_file_name(f)).string();
    const std::vector<uint16_t> inst = scene::decode_png_gray16(scene::read_file(name), name, &w, &h);
    std::map<uint16_t, size_t> counts;
    for (uint16_t i : inst)
      if (i >= lift::kDynamicInstanceMin) ++counts[i];
    const std::map<uint16_t, glm::dmat4> poses = lift::dynamic_object_poses(sc, meta.source_time_indices[f]);
    for (const auto& [id, count] : counts) {
      if (count <= car_pixels || !poses.count(id)) continue;
      const glm::dvec3 c = glm::dvec3(glm::inverse(meta.poses[f]) * poses.at(id)[3]);
      if (c.z < 3.0) continue;
      car = id, car_frame = f, car_pixels = count, depth = c.z;
    }
  }
  REQUIRE_MESSAGE(car != 0, "no moving car in the demo's key frames");
  MESSAGE("car " << car << " in key frame " << car_frame << ": " << car_pixels << " pixels at " << depth << " m");

  // Random weights of gsm_small's structure with the pixel branch's depth pinned to the car's: linear_out's
  // depth rows zero, their bias the logit of (depth - 0.5) / 299.5.
  const fs::path model = dir.path / "model";
  fs::create_directories(model);
  fs::copy_file(small_config, model / "gsm_config.json");
  const nn::GsmModelConfig cfg = nn::load_gsm_model_config((model / "gsm_config.json").string());
  const std::vector<nn::GsmParamSpec> specs = nn::gsm_param_specs(cfg);
  const nn::GsmConfig& c = cfg.config;
  auto weights_with = [&](const std::function<void(nn::GsmWeights&)>& edit) {
    nn::GsmWeights w = nn::gsm_random_weights(specs, 5);
    const int gd = c.pixel.gs_dim;
    nn::CpuTensor& lw = w.tensors.at("backbone.backbone_2d.linear_out.weight");
    nn::CpuTensor& lb = w.tensors.at("backbone.backbone_2d.linear_out.bias");
    const int64_t in = lw.dim(1);
    const double p = (depth - c.pixel.znear) / (c.pixel.zfar - c.pixel.znear);
    for (int g = 0; g < c.pixel.gs_per_pixel; ++g) {
      for (int64_t k = 0; k < in; ++k) lw.data[size_t(g * gd * in + k)] = 0.0f;
      lb.data[size_t(g * gd)] = float(std::log(p / (1.0 - p)));
    }
    if (edit) edit(w);
    return nn::gsm_weight_file_tensors(std::move(w), specs);
  };
  nn::write_safetensors((model / "gsm.safetensors").string(), weights_with({}));

  const fs::path out = dir.path / "lifted";
  const std::string base = "lift '" + demo.world + "' '" + frames.string() + "' --scene '" + demo.scene + "' ";
  const std::string opts = "--gsm-radius 5 --gsm-size 208x112 ";
  const test::CliRun r = test::run_icube(base + "--gsm '" + model.string() + "' " + opts + "-o '" + out.string() + "'", dir.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  MESSAGE(r.output.substr(r.output.rfind("lift (gsm)")));
  for (const char* f : {"gaussians_static.ply", "sky.png", "scene.json", "lift_report.json", "eval.png"})
    CHECK(fs::is_regular_file(out / f));
  const auto rep = nlohmann::json::parse(scene::read_file((out / "lift_report.json").string()));
  CHECK(rep["method"] == "gsm");
  CHECK(rep["key_frames"] == nlohmann::json::array({0, 6}));
  CHECK(rep["options"]["input_size"] == nlohmann::json::array({208, 112}));
  CHECK(rep["held_out"].size() == 4);
  const auto& gs = rep["gsm"];
  const size_t V = gs["input_voxels"], front = gs["front_voxels"], nvox = rep["gaussians"]["voxel"],
               npix = rep["gaussians"]["pixel"];
  // The voxel branch: 4 Gaussians per 0.1 m child of each first-hit voxel (8 each) and per other voxel.
  CHECK(front > 0);
  CHECK(nvox == 4 * (8 * front + (V - front)));
  // The package's static set is the model's: voxel then pixel Gaussians.
  const splat::SplatScene scn = splat::read_splat_scene((out / "scene.json").string());
  CHECK(scn.static_set.size() == nvox + npix);
  CHECK(rep["gaussians"]["total"] == nvox + npix);

  // The pixel branch: 2 Gaussians per mid-ground pixel of the last key frame (the folder's sky mask says
  // not sky, the model's grid has no run of voxels on the pixel's ray); none in the earlier key frame.
  {
    const world::VoxelGrid world = render::make_static_world(world::load_world(demo.world), sc,
                                                             std::max(0, meta.source_time_indices[0]), world::builtin_car_mesh());
    std::vector<glm::dvec3> cams = {glm::dvec3(meta.poses[0][3]), glm::dvec3(meta.poses[6][3])};
    const lift::GsmGridFrame g = lift::gsm_grid_frame(world, cams[0], demo.world);
    nn::GsmInputs in;
    in.batch = 1, in.views = 1, in.width = 208, in.height = 112;
    in.voxel_ijk = {lift::gsm_crop_voxels(world, g, cams, 5.0)};
    CHECK(in.voxel_ijk[0].size() == V);
    in.poses = {lift::gsm_pose(meta.poses[6], g)};
    in.intrinsics = {lift::gsm_intrinsics(meta.K, meta.pixels, 208, 112)};
    const nn::GsmPixelRays rays = nn::cast_gsm_pixel_rays(in, 0);
    const lift::GsmFrame f6 = lift::gsm_frame(lift::read_frame_images(frames.string(), meta, 6), meta.width, meta.height, 208, 112);
    size_t mid = 0;
    for (size_t p = 0; p < f6.sky.size(); ++p) mid += !f6.sky[p] && !rays.grid_foreground[p];
    CHECK(mid > 0);
    CHECK(npix == 2 * mid);
    CHECK(gs["midground_pixels"] == mid);
  }

  // The sky: the model's panorama, 512 x 256.
  const scene::Image8 sky = scene::read_png((out / "sky.png").string(), 4);
  CHECK(sky.width == 512);
  CHECK(sky.height == 256);

  // The dynamic pass: the car's Gaussians in its box frame, placed by its track.
  CHECK(gs["dynamic_views"].get<size_t>() >= 1);
  const splat::SplatObject* obj = nullptr;
  for (const splat::SplatObject& o : scn.objects)
    if (o.id == car) obj = &o;
  REQUIRE(obj != nullptr);
  CHECK(obj->gaussians.size() > 0);
  CHECK(obj->gaussians.size() <= 2 * car_pixels);
  const scene::BoxState* box = nullptr;
  for (const scene::Track& t : sc.tracks)
    if (t.instance_id == car) box = scene::state_filled(t, meta.source_time_indices[car_frame]);
  REQUIRE(box != nullptr);
  for (const glm::dvec3& p : obj->gaussians.positions) {
    CHECK(std::fabs(p.x) <= box->length / 2 + 1e-4);
    CHECK(std::fabs(p.y) <= box->width / 2 + 1e-4);
    CHECK(std::fabs(p.z) <= box->height / 2 + 1e-4);
  }
  const size_t sf = lift::splat_frame_of(meta, car_frame);
  REQUIRE(obj->pose(sf) != nullptr);
  CHECK(glm::length(glm::dvec3((*obj->pose(sf))[3]) - box->center) < 1e-9);

  // Refused before any work, nothing written: a non-finite weight, weights of another configuration, a
  // folder without weights, frames the model cannot take without --gsm-size.
  const fs::path none = dir.path / "none";
  auto refused = [&](const std::string& args, const std::string& message) {
    const test::CliRun e = test::run_icube(base + args + " -o '" + none.string() + "'", dir.path);
    CAPTURE(args);
    INFO(e.output);
    CHECK(e.code != 0);
    CHECK(e.output.find(message) != std::string::npos);
    CHECK_FALSE(fs::exists(none));
  };
  const fs::path nan_model = dir.path / "nan-model";
  fs::create_directories(nan_model);
  fs::copy_file(model / "gsm_config.json", nan_model / "gsm_config.json");
  nn::write_safetensors((nan_model / "gsm.safetensors").string(), weights_with([](nn::GsmWeights& w) {
                          w.tensors.at("skybox.sky_query").data[1] = std::numeric_limits<float>::quiet_NaN();
                        }));
  refused("--gsm '" + nan_model.string() + "' " + opts, "skybox.sky_query");
  refused("--gsm-model infinicube-gsm --gsm-weights '" + (model / "gsm.safetensors").string() + "' " + opts, "gsm.safetensors");
  fs::remove(nan_model / "gsm.safetensors");
  refused("--gsm '" + nan_model.string() + "' " + opts, "gsm.safetensors: missing");
  refused("--gsm '" + model.string() + "' --gsm-radius 5", "not made of whole 16-pixel patches");
  refused("--gsm '" + model.string() + "' --gsm-model infinicube-gsm " + opts, "give --gsm DIR or --gsm-model");
}
