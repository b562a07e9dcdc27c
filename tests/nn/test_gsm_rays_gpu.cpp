// The GSM's pixel rays on the engine's voxel ray caster (engine/nn/gsm/gsm_rays_gpu.h:
// shaders/raycast/cast.comp in ray-list mode with RAYCAST_MARK_TIES, marked rays re-marched in
// double) against the double reference cast_gsm_pixel_rays (engine/nn/gsm/gsm_rays.h), pixel for
// pixel: the first voxel's row and the grid-foreground mask exactly, the voxel depth within
// 2e-6 m + 1e-6 relative (float t of the same run start). Cases: gsm_small's view and its
// reference tensors; the two-view batch of two; a random street of odd size (37 x 23) with
// tilted cameras; a tie-heavy grid (an axis-aligned camera on voxel corners, integer intrinsics,
// a checkerboard of voxels: rays through edges and corners) where the marking must act and where
// the float walk alone, without the re-check, differs at some pixels; the same street 100 km from
// the grid origin. Runs under the validation layer.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "gsm_case.h"
#include "nn/gsm/gsm_rays.h"
#include "nn/gsm/gsm_rays_gpu.h"

#include <cmath>
#include <cstdio>
#include <random>
#include <set>

using namespace icube;

namespace {

// Pixel-for-pixel agreement; prints the first mismatches and the share of re-checked rays.
void check_same(const nn::GsmPixelRays& got, const nn::GsmPixelRays& want, const nn::GsmRayCastStats& stats,
                const char* what) {
  REQUIRE(got.first_voxel.size() == want.first_voxel.size());
  size_t bad = 0, hits = 0, depths = 0;
  double worst = 0.0;
  for (size_t p = 0; p < want.first_voxel.size(); ++p) {
    hits += want.first_voxel[p] >= 0;
    depths += want.voxel_depth[p] != 0.0f;
    const double dd = std::fabs(double(got.voxel_depth[p]) - double(want.voxel_depth[p]));
    worst = std::max(worst, dd);
    const bool ok = got.first_voxel[p] == want.first_voxel[p] && got.grid_foreground[p] == want.grid_foreground[p] &&
                    dd <= 2e-6 + 1e-6 * std::fabs(double(want.voxel_depth[p]));
    if (!ok && bad++ < 8)
      std::printf("  %s pixel %zu: first %d vs %d, foreground %d vs %d, depth %.9g vs %.9g\n", what, p,
                  got.first_voxel[p], want.first_voxel[p], got.grid_foreground[p], want.grid_foreground[p],
                  double(got.voxel_depth[p]), double(want.voxel_depth[p]));
  }
  std::printf("gsm rays gpu %s: %zu pixels (%zu hit, %zu with depth), %llu re-checked in double, worst depth diff %.3g m,"
              " %zu mismatches\n",
              what, want.first_voxel.size(), hits, depths, static_cast<unsigned long long>(stats.rechecked), worst, bad);
  CHECK(bad == 0);
}

// Each voxel once, in first-listed order.
std::vector<nn::Ijk> unique_voxels(const std::vector<nn::Ijk>& v) {
  std::set<nn::Ijk> seen;
  std::vector<nn::Ijk> out;
  for (const nn::Ijk& x : v)
    if (seen.insert(x).second) out.push_back(x);
  return out;
}

// A street: a ground plane, two walls and boxes (cars), random holes; camera poses looking down the street.
nn::GsmInputs street(int64_t W, int64_t H, int views, double offset_m, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  nn::GsmInputs in;
  in.batch = 1;
  in.views = views;
  in.height = H;
  in.width = W;
  const int32_t off = static_cast<int32_t>(std::lround(offset_m / nn::kGsmVoxelSize));
  std::vector<nn::Ijk> v;
  for (int32_t i = -40; i < 200; ++i)
    for (int32_t j = -50; j < 50; ++j) {
      if (u(rng) < 0.97) v.push_back({off + i, off + j, 0});           // road, with holes
      if (j == -50 || j == 49)
        for (int32_t k = 1; k < 25; ++k) v.push_back({off + i, off + j, k});  // walls
    }
  for (int car = 0; car < 12; ++car) {
    const int32_t ci = 10 + static_cast<int32_t>(u(rng) * 170), cj = -40 + static_cast<int32_t>(u(rng) * 75);
    for (int32_t i = ci; i < ci + 22; ++i)
      for (int32_t j = cj; j < cj + 9; ++j)
        for (int32_t k = 1; k < 8; ++k)
          if (i == ci || i == ci + 21 || j == cj || j == cj + 8 || k == 7) v.push_back({off + i, off + j, k});
  }
  in.voxel_ijk = {unique_voxels(v)};
  const float base = static_cast<float>(offset_m);
  for (int n = 0; n < views; ++n) {
    // OpenCV camera (x right, y down, z forward) looking along grid +x, yawed and pitched a little.
    const double yaw = 0.3 * (u(rng) - 0.5) + 0.9 * n, pitch = 0.08 * (u(rng) - 0.5) - 0.05;
    const double cy_ = std::cos(yaw), sy = std::sin(yaw), cp = std::cos(pitch), sp = std::sin(pitch);
    const double fwd[3] = {cy_ * cp, sy * cp, sp}, left[3] = {-sy, cy_, 0.0};
    const double up[3] = {fwd[1] * left[2] - fwd[2] * left[1], fwd[2] * left[0] - fwd[0] * left[2],
                          fwd[0] * left[1] - fwd[1] * left[0]};
    std::array<float, 16> pose{};
    for (int r = 0; r < 3; ++r) {
      pose[static_cast<size_t>(4 * r + 0)] = static_cast<float>(-left[r]);
      pose[static_cast<size_t>(4 * r + 1)] = static_cast<float>(-up[r]);
      pose[static_cast<size_t>(4 * r + 2)] = static_cast<float>(fwd[r]);
    }
    pose[3] = base + static_cast<float>(1.0 + 3.0 * n + u(rng));
    pose[7] = base + static_cast<float>(u(rng) - 0.5);
    pose[11] = static_cast<float>(1.5 + 0.2 * u(rng));
    pose[15] = 1.0f;
    in.poses.push_back(pose);
    in.intrinsics.push_back({0.9f * static_cast<float>(W), 0.9f * static_cast<float>(W), 0.5f * static_cast<float>(W),
                             0.5f * static_cast<float>(H), static_cast<float>(W), static_cast<float>(H)});
  }
  return in;
}

// Ties everywhere: an axis-aligned camera at a voxel corner, integer focal length and principal point
// (pixel rays with rational slopes through voxel edges and corners), a checkerboard floor and wall
// blocks one voxel thick (runs of 0.2 m) and half-voxel starts (runs of exactly 0.1 m).
nn::GsmInputs tie_grid(float centre_x, float centre_y, float centre_z) {
  nn::GsmInputs in;
  in.batch = 1;
  in.views = 1;
  in.height = 31;
  in.width = 41;
  std::vector<nn::Ijk> v;
  for (int32_t i = -30; i < 30; ++i)
    for (int32_t j = -30; j < 30; ++j) {
      if (((i + j) & 1) == 0) v.push_back({i, j, -4});       // checkerboard floor
      if (((i ^ j) & 3) == 0) v.push_back({i, j, 6});        // sparse ceiling
    }
  for (int32_t j = -30; j < 30; ++j)
    for (int32_t k = -4; k < 7; ++k)
      if (((j + k) % 3) != 0) v.push_back({12, j, k});         // a wall with slits
  in.voxel_ijk = {unique_voxels(v)};
  // Camera looking along grid +x (OpenCV: x right = -y grid, y down = -z grid, z forward = +x grid),
  // its centre on the voxel corner x = 0, y = 0, z = 0 of the lattice [ijk, ijk+1) in (x - 0.1)/0.2 + 0.5.
  std::array<float, 16> pose{};
  pose[0 * 4 + 2] = 1.0f;   // grid x = camera z
  pose[1 * 4 + 0] = -1.0f;  // grid y = -camera x
  pose[2 * 4 + 1] = -1.0f;  // grid z = -camera y
  pose[3] = centre_x;
  pose[7] = centre_y;
  pose[11] = centre_z;
  pose[15] = 1.0f;
  in.poses = {pose};
  in.intrinsics = {{10.0f, 10.0f, 20.0f, 15.0f, 41.0f, 31.0f}};
  return in;
}

// Pixels where the float walk alone (no re-check) differs from the double reference.
size_t float_walk_differences(const nn::GsmInputs& in) {
  nn::GsmRayCastStats stats;
  const nn::GsmPixelRays got = nn::cast_gsm_pixel_rays_gpu(test::gpu_context(), in, 0, &stats, false);
  const nn::GsmPixelRays want = nn::cast_gsm_pixel_rays(in, 0);
  size_t n = 0;
  for (size_t p = 0; p < want.first_voxel.size(); ++p)
    n += got.first_voxel[p] != want.first_voxel[p] || got.grid_foreground[p] != want.grid_foreground[p] ||
         std::fabs(double(got.voxel_depth[p]) - double(want.voxel_depth[p])) > 1e-3;
  std::printf("gsm rays gpu: the float walk alone differs from double at %zu of %zu pixels (%llu marked)\n", n,
              want.first_voxel.size(), static_cast<unsigned long long>(stats.rechecked));
  return n;
}

void run_case(const nn::GsmInputs& in, const char* what, bool expect_rechecks) {
  gpu::Context& ctx = test::gpu_context();
  for (int64_t b = 0; b < in.batch; ++b) {
    nn::GsmRayCastStats stats;
    const nn::GsmPixelRays got = nn::cast_gsm_pixel_rays_gpu(ctx, in, b, &stats);
    const nn::GsmPixelRays want = nn::cast_gsm_pixel_rays(in, b);
    CHECK(stats.rays == want.first_voxel.size());
    check_same(got, want, stats, what);
    if (expect_rechecks) CHECK(stats.rechecked > 0);
  }
}

}  // namespace

TEST_CASE("gsm_rays_gpu: gsm_small's view and the two-view batch of two equal the double reference") {
  const std::string dir = test::gsm_small_dir();
  if (dir.empty()) return;
  const nn::GsmInputs in = nn::read_gsm_inputs(dir + "inputs");
  run_case(in, "gsm_small", false);
  // And the reference tensors themselves (the official code's first voxels and masks).
  const test::GsmTensors ref(dir + "intermediates.safetensors");
  nn::GsmTrace trace;
  std::vector<nn::GsmPixelRays> all{nn::cast_gsm_pixel_rays_gpu(test::gpu_context(), in, 0)};
  nn::trace_gsm_pixel_rays(all, &trace);
  for (const char* name : {"vox.lifter.pixel_first_voxel.b0", "pre.grid_fg_mask", "pix.voxel_depth"})
    CHECK(test::check_gsm_tensor(ref, name, trace.tensors.at(name)));
  run_case(test::gsm_two_view_batch(dir), "two-view batch of two", false);
}

TEST_CASE("gsm_rays_gpu: a street of odd size with tilted cameras equals the double reference") {
  run_case(street(37, 23, 3, 0.0, 7u), "street 37x23", false);
}

TEST_CASE("gsm_rays_gpu: rays through voxel edges and corners are marked and decided as in double") {
  // The camera on a voxel corner (every ray starts on three planes: all marked), then in a voxel's
  // centre (rays through edges and corners further on: some marked).
  run_case(tie_grid(0.0f, 0.0f, 0.0f), "tie grid, camera on a corner", true);
  const nn::GsmInputs centred = tie_grid(0.1f, 0.1f, 0.1f);
  run_case(centred, "tie grid, camera in a voxel centre", true);
  // Without the re-check the float walk decides some of these ties otherwise: the marking is what
  // makes them equal.
  CHECK(float_walk_differences(centred) > 0);
  CHECK(float_walk_differences(tie_grid(0.0f, 0.0f, 0.0f)) > 0);
}

TEST_CASE("gsm_rays_gpu: the street 100 km from the grid origin equals the double reference") {
  run_case(street(29, 17, 2, 100000.0, 11u), "street at 100 km", false);
}
