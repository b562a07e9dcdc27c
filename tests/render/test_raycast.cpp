// The voxel ray caster: shaders/raycast/cast.comp (engine/render/raycast_gpu.h)
// against the double-precision brute-force DDA (engine/render/raycast_cpu.h)
// on fixed-seed random worlds and cameras (odd image sizes; the exact pass on
// the device's route and forced float-only, raycast/exact_df.comp), and both against
// hand-computed answers for the stiff cases: axis-parallel rays, origins on
// faces / edges / corners, grazing rays, a camera inside a voxel, an empty and
// a single-voxel world, a camera 100 km from the origin, eps_sem vs eps_depth.
// Stiff cases use voxel size 0.25 m (exact in binary) unless they say otherwise.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "raycast_test_util.h"
#include "render/raycast_cpu.h"
#include "render/raycast_gpu.h"
#include "world/gpu_world.h"

#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

using namespace icube;
using render::Ray;
using render::RayResult;
using world::VoxelGrid;
using namespace icube::raytest;

namespace {
VoxelGrid random_voxel_world(uint32_t seed, int n, int extent, double vs) {
  VoxelGrid g(glm::dvec3(0.0), vs);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(-extent, extent), c(1, 22), inst(0, 65535);
  for (int i = 0; i < n; ++i) g.set({d(rng), d(rng), d(rng)}, static_cast<uint8_t>(c(rng)), static_cast<uint16_t>(inst(rng)));
  return g;
}

// A ground slab, solid boxes, thin axis slabs and hollow shells, shifted by `shift` voxels.
VoxelGrid random_box_world(uint32_t seed, const glm::ivec3& shift = glm::ivec3(0), double vs = 0.2) {
  VoxelGrid g(glm::dvec3(0.0), vs);
  std::mt19937 rng(seed);
  auto put = [&](int i, int j, int k, int cls, int inst) {
    g.set(glm::ivec3(i, j, k) + shift, static_cast<uint8_t>(cls), static_cast<uint16_t>(inst));
  };
  for (int i = -60; i < 60; ++i)
    for (int j = -60; j < 60; ++j) put(i, j, -1, 17, 0);  // ground (one voxel thick)
  std::uniform_int_distribution<int> pos(-50, 45), sz(1, 9), kind(0, 2), cls(1, 22);
  for (int b = 0; b < 40; ++b) {
    const int x0 = pos(rng), y0 = pos(rng), z0 = std::uniform_int_distribution<int>(0, 20)(rng);
    int sx = sz(rng), sy = sz(rng), sz_ = sz(rng);
    const int k = kind(rng), c = cls(rng);
    if (k == 1) (b % 3 == 0 ? sx : b % 3 == 1 ? sy : sz_) = 1;  // thin slab
    for (int i = 0; i < sx; ++i)
      for (int j = 0; j < sy; ++j)
        for (int l = 0; l < sz_; ++l) {
          const bool shell = i == 0 || j == 0 || l == 0 || i == sx - 1 || j == sy - 1 || l == sz_ - 1;
          if (k != 2 || shell) put(x0 + i, y0 + j, z0 + l, c, b + 1);
        }
  }
  return g;
}


std::vector<RayResult> gpu_rays(const VoxelGrid& g, const std::vector<Ray>& rays, const render::RaycastOptions& o = {}) {
  const render::RaycastWorld w = render::upload_raycast_world(test::gpu_context(), g);
  render::RaycasterGpu rc(test::gpu_context());
  return from_gpu(rc.cast_rays(w, rays, o));
}

// float_only: the exact pass in double-float (raycast/exact_df.comp) even where the device has shaderFloat64.
std::vector<RayResult> gpu_camera(const VoxelGrid& g, const render::Camera& cam, const render::RaycastOptions& o = {},
                                  bool float_only = false) {
  const render::RaycastWorld w = render::upload_raycast_world(test::gpu_context(), g);
  render::RaycasterGpu rc(test::gpu_context());
  rc.set_exact_float_only(float_only);
  return from_gpu(rc.cast_camera(w, cam, o));
}

// GPU and CPU on the same rays; both must agree (all rays) and the CPU must give `want`.
void check_ray(const VoxelGrid& g, const Ray& ray, const RayResult& want, const render::RaycastOptions& o = {}) {
  const RayResult cpu = render::cast_ray_cpu(g, render::raycast_bounds(g), ray, o);
  const RayResult gpu = gpu_rays(g, {ray}, o).at(0);
  for (const RayResult* r : {&cpu, &gpu}) {
    CAPTURE(r == &cpu ? "cpu" : "gpu");
    CHECK(r->sem_hit == want.sem_hit);
    CHECK(r->depth_hit == want.depth_hit);
    if (want.sem_hit) {
      CHECK(r->ijk == want.ijk);
      CHECK(r->class_id == want.class_id);
      CHECK(r->normal == want.normal);
      CHECK(std::fabs(r->t_sem - want.t_sem) <= 1e-6);
    }
    if (want.depth_hit) CHECK(std::fabs(r->t_depth - want.t_depth) <= 1e-6);
    if (!want.depth_hit) CHECK(r->t_depth == 0.0);
  }
}

RayResult hit(glm::ivec3 ijk, int cls, double t, int normal, bool depth = true, double t_depth = -1.0) {
  RayResult r;
  r.sem_hit = true;
  r.ijk = ijk;
  r.class_id = static_cast<uint8_t>(cls);
  r.t_sem = t;
  r.normal = normal;
  r.depth_hit = depth;
  r.t_depth = depth ? (t_depth < 0.0 ? t : t_depth) : 0.0;
  return r;
}

constexpr double kVs = 0.25;

}  // namespace

TEST_CASE("raycast: camera rays follow the integer-pixel convention") {
  render::Camera c = make_camera(5, 3, 100.0, glm::dvec3(1, 2, 3), glm::dmat3(1.0));
  c.K.cx = 2.0;
  c.K.cy = 1.0;
  const Ray r = render::camera_ray(c, 2, 1, render::PixelConvention::Integer);
  CHECK(r.dir.z == doctest::Approx(1.0));
  CHECK(std::fabs(r.dir.x) < 1e-15);
  CHECK(r.origin == glm::dvec3(1, 2, 3));
  const Ray rc = render::camera_ray(c, 2, 1, render::PixelConvention::Centre);
  CHECK(rc.dir.x == doctest::Approx(0.5 / 100.0 / std::sqrt(1 + 0.25e-4 + std::pow(0.5 / 107.0, 2))));
  const std::vector<Ray> all = render::camera_rays(c, render::PixelConvention::Integer);
  REQUIRE(all.size() == 15);
  CHECK(all[1 * 5 + 2].dir == r.dir);
  CHECK_THROWS_AS(render::validate_camera(make_camera(0, 3, 1.0, {}, glm::dmat3(1.0))), std::invalid_argument);
}

TEST_CASE("raycast: GPU matches the CPU reference on random worlds and cameras (exact pass in double and float-only)") {
  Agreement total, total_df;
  const double vs = 0.2;
  int image = 0;
  for (uint32_t seed = 1; seed <= 18; ++seed) {
    CAPTURE(seed);
    const bool boxes = seed % 2 == 0;
    const VoxelGrid g = boxes ? random_box_world(seed) : random_voxel_world(seed, 2500, 40, vs);
    std::mt19937 rng(seed * 7919u);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    glm::dvec3 pos;
    glm::dmat3 R;
    if (seed % 3 == 0) {  // far outside, looking at the world
      pos = glm::dvec3(u(rng), u(rng), 0.5 + 0.5 * u(rng)) * 30.0;
      pos += glm::normalize(pos) * 10.0;
      R = look_at(pos, glm::dvec3(u(rng), u(rng), u(rng)) * 2.0);
    } else {  // inside, random orientation
      pos = glm::dvec3(u(rng) * 8.0, u(rng) * 8.0, 0.3 + std::fabs(u(rng)) * 4.0);
      R = random_rotation(rng);
    }
    const uint32_t w = seed % 4 == 1 ? 97 : 83, h = seed % 4 == 1 ? 61 : 67;
    render::Camera cam = make_camera(w, h, 40.0 + 10.0 * seed, pos, R);
    render::RaycastOptions o;
    o.pixels = seed % 5 == 0 ? render::PixelConvention::Centre : render::PixelConvention::Integer;
    const auto gpu = gpu_camera(g, cam, o);
    const auto cpu = render::cast_camera_cpu(g, cam, o, 2);
    const Agreement a = compare(gpu, cpu, 1e-3 * vs, "random");
    add(total, a);
    add(total_df, compare(gpu_camera(g, cam, o, true), cpu, 1e-3 * vs, "random, float-only"));
    ++image;
  }
  std::printf("raycast random, float-only exact pass (double-float chords): %zu rays, %zu disagree, %zu other entry "
              "face, max |dt| %.3g m\n",
              total_df.rays, total_df.disagree, total_df.normal_only, total_df.max_dt);
  CHECK(static_cast<double>(total_df.disagree) <= 1e-5 * static_cast<double>(total_df.rays));
  CHECK(static_cast<double>(total_df.normal_only) <= 1e-4 * static_cast<double>(total_df.rays));
  CHECK(total_df.max_dt <= 1e-3 * vs);
  std::printf("raycast random: %d images, %zu rays, %zu semantic hits, %zu depth hits, %zu disagree, %zu other entry face, "
              "max |dt| %.3g m\n",
              image, total.rays, total.sem_hits, total.depth_hits, total.disagree, total.normal_only, total.max_dt);
  CHECK(total.rays >= 100000);
  CHECK(total.sem_hits > total.rays / 4);
  CHECK(total.sem_hits < total.rays);
  CHECK(static_cast<double>(total.disagree) <= 1e-5 * static_cast<double>(total.rays));
  CHECK(static_cast<double>(total.normal_only) <= 1e-4 * static_cast<double>(total.rays));
  CHECK(total.max_dt <= 1e-3 * vs);
}

TEST_CASE("raycast: lattice-aligned ray lists (axis, face and body diagonals) match the CPU") {
  // Origins on voxel corners, edge midpoints, face centres and voxel centres;
  // directions with zero components: every tie and zero-chord path.
  const VoxelGrid g = [] {
    VoxelGrid v = random_box_world(77, glm::ivec3(0), kVs);
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> d(-30, 30), c(1, 22);
    for (int i = 0; i < 800; ++i) v.set({d(rng), d(rng), std::abs(d(rng)) / 2}, static_cast<uint8_t>(c(rng)), 9);
    return v;
  }();
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> cell(-20, 20), half(0, 1), comp(-2, 2);
  std::vector<Ray> rays;
  while (rays.size() < 20000) {
    glm::dvec3 o;
    for (int a = 0; a < 3; ++a) o[a] = (cell(rng) + 0.5 * half(rng)) * kVs;
    o.z = std::fabs(o.z) * 0.5;
    glm::dvec3 d(comp(rng), comp(rng), comp(rng));
    if (d == glm::dvec3(0.0)) continue;
    rays.push_back({o, glm::normalize(d)});
  }
  const auto gpu = gpu_rays(g, rays);
  const auto cpu = render::cast_rays_cpu(g, rays, {}, 2);
  const Agreement a = compare(gpu, cpu, 1e-3 * kVs, "lattice");
  std::printf("raycast lattice: %zu rays, %zu semantic hits, %zu disagree, max |dt| %.3g m\n", a.rays, a.sem_hits,
              a.disagree, a.max_dt);
  CHECK(a.disagree == 0);
  CHECK(a.normal_only == 0);  // exact ties resolve in the same x, y, z order on both
  CHECK(a.sem_hits > a.rays / 4);
}

TEST_CASE("raycast: axis-parallel rays along +-x, +-y, +-z") {
  VoxelGrid g(glm::dvec3(0.0), kVs);
  // One target 10 voxels away along each axis from the centre of voxel 0.
  for (int a = 0; a < 3; ++a)
    for (int s : {-1, 1}) {
      glm::ivec3 ijk(0);
      ijk[a] = 10 * s;
      g.set(ijk, static_cast<uint8_t>(1 + 2 * a + (s > 0)), 0);
    }
  const glm::dvec3 centre(0.5 * kVs);
  for (int a = 0; a < 3; ++a)
    for (int s : {-1, 1}) {
      CAPTURE(a);
      CAPTURE(s);
      glm::dvec3 d(0.0);
      d[a] = s;
      glm::ivec3 ijk(0);
      ijk[a] = 10 * s;
      check_ray(g, {centre, d}, hit(ijk, 1 + 2 * a + (s > 0), 9.5 * kVs, -(a + 1) * s));
      // From outside the bounds (far away on the same axis), the ray first meets the near target.
      glm::dvec3 far = centre;
      far[a] = -s * 100.0 * kVs;
      glm::ivec3 near(0);
      near[a] = -10 * s;
      check_ray(g, {far, d}, hit(near, 1 + 2 * a + (s < 0), (s > 0 ? 90.0 : 89.0) * kVs,
                                 -(a + 1) * s));
    }
  // +x ray exactly on the face y = 0 belongs to voxels y = 0 (half-open cells), so it reaches (10, 0, 0)...
  check_ray(g, {glm::dvec3(0.5, 0.0, 0.5) * kVs, {1, 0, 0}}, hit({10, 0, 0}, 2, 9.5 * kVs, -1));
  // ...and on the face y = 1 it belongs to y = 1: nothing there.
  check_ray(g, {glm::dvec3(0.5, 1.0, 0.5) * kVs, {1, 0, 0}}, RayResult{});
}

TEST_CASE("raycast: rays starting exactly on a face, an edge and a corner") {
  VoxelGrid g(glm::dvec3(0.0), kVs);
  g.set({2, 0, 0}, 3, 1);  // -x of the face x = 3
  g.set({2, 3, 0}, 4, 2);  // across the edge x = 3, y = 4 (z in [0, 1))
  g.set({2, 3, 4}, 5, 3);  // across the corner (3, 4, 5)
  g.set({3, 4, 5}, 6, 4);  // on the other side of that corner
  // Face: origin on x = 3 going -x enters (2,0,0) at t = 0 through its +x face.
  check_ray(g, {glm::dvec3(3.0, 0.5, 0.5) * kVs, {-1, 0, 0}}, hit({2, 0, 0}, 3, 0.0, +1));
  // Going +x from the same point: (3,0,0) is empty, nothing further.
  check_ray(g, {glm::dvec3(3.0, 0.5, 0.5) * kVs, {1, 0, 0}}, RayResult{});
  // Edge: origin on the edge (3, 4, z = 0.5) going (-1, -1, 0): zero-length (2,4,0) first (x steps
  // before y on ties), then (2,3,0) entered through its +y face.
  check_ray(g, {glm::dvec3(3.0, 4.0, 0.5) * kVs, glm::normalize(glm::dvec3(-1, -1, 0))}, hit({2, 3, 0}, 4, 0.0, +2));
  // Corner: (-1,-1,-1) from (3,4,5) reaches (2,3,4) at t = 0 (last step z: normal +z).
  check_ray(g, {glm::dvec3(3.0, 4.0, 5.0) * kVs, glm::normalize(glm::dvec3(-1, -1, -1))}, hit({2, 3, 4}, 5, 0.0, +3));
  // (1,1,1) from the corner starts inside (3,4,5): t = 0, no entry face.
  check_ray(g, {glm::dvec3(3.0, 4.0, 5.0) * kVs, glm::normalize(glm::dvec3(1, 1, 1))}, hit({3, 4, 5}, 6, 0.0, 0));
  // 45 degree diagonal through edges from outside: (0.5, 1.5) -> (2,3,0) entered at x = 2, y = 3 exactly (an edge).
  const double t_edge = std::sqrt(2.0) * 1.5 * kVs;
  check_ray(g, {glm::dvec3(0.5, 1.5, 0.5) * kVs, glm::normalize(glm::dvec3(1, 1, 0))}, hit({2, 3, 0}, 4, t_edge, -2));
}

TEST_CASE("raycast: grazing rays along a face") {
  VoxelGrid g(glm::dvec3(0.0), kVs);
  for (int i = 0; i < 20; ++i) g.set({i, -1, 0}, 8, 0);  // a row just below the plane y = 0
  // Exactly in the plane y = 0: the ray is in the y = 0 cells (half-open), never in the row.
  check_ray(g, {glm::dvec3(-3.0, 0.0, 0.5) * kVs, {1, 0, 0}}, RayResult{});
  // Just below the plane (inside the row): full hit at the row's start.
  check_ray(g, {glm::dvec3(-3.0, -1e-4, 0.5) * kVs, {1, 0, 0}}, hit({0, -1, 0}, 8, 3.0 * kVs, -1));
  // Sloping down onto the row: enters through the top face (y = 0) at x = 5.
  const glm::dvec3 dir = glm::normalize(glm::dvec3(10.0, -1.0, 0.0));
  const glm::dvec3 o = glm::dvec3(-5.0, 1.0, 0.5) * kVs;
  check_ray(g, {o, dir}, hit({5, -1, 0}, 8, glm::length(glm::dvec3(10.0, 1.0, 0.0)) * kVs, +2));
}

TEST_CASE("raycast: camera inside an occupied voxel") {
  VoxelGrid g(glm::dvec3(0.0), kVs);
  g.set({0, 0, 0}, 11, 42);
  // Every ray from the voxel centre: chord 0.5..0.87 voxel >= eps on both: hit at t = 0, no face.
  render::Camera cam = make_camera(9, 7, 3.0, glm::dvec3(0.5 * kVs), glm::dmat3(1.0));
  const auto gpu = gpu_camera(g, cam);
  const auto cpu = render::cast_camera_cpu(g, cam, {});
  REQUIRE(gpu.size() == 63);
  for (const auto* rs : {&gpu, &cpu})
    for (const RayResult& r : *rs) {
      CHECK(r.sem_hit);
      CHECK(r.depth_hit);
      CHECK(r.t_sem == 0.0);
      CHECK(r.t_depth == 0.0);
      CHECK(r.normal == 0);
      CHECK(r.class_id == 11);
      CHECK(r.instance == 42);
      CHECK(r.ijk == glm::ivec3(0));
    }
  // Near the voxel's +x face looking +x: chord 0.01 voxel = 2.5 mm < eps_sem: nothing.
  check_ray(g, {glm::dvec3(0.99, 0.5, 0.5) * kVs, {1, 0, 0}}, RayResult{});
}

TEST_CASE("raycast: empty world, every ray misses") {
  const VoxelGrid g(glm::dvec3(0.0), 0.2);
  render::Camera cam = make_camera(31, 17, 20.0, glm::dvec3(1.0, 2.0, 3.0), glm::dmat3(1.0));
  const auto gpu = gpu_camera(g, cam);
  REQUIRE(gpu.size() == 31u * 17u);
  for (const RayResult& r : gpu) CHECK((!r.sem_hit && !r.depth_hit && r.t_depth == 0.0 && r.class_id == 0));
  for (const RayResult& r : render::cast_camera_cpu(g, cam, {})) CHECK((!r.sem_hit && !r.depth_hit));
  CHECK(gpu_rays(g, {Ray{}}).at(0).sem_hit == false);
  // An erased world (bricks gone) also misses.
  VoxelGrid e(glm::dvec3(0.0), 0.2);
  e.set({1, 2, 3}, 4);
  e.erase({1, 2, 3});
  CHECK(gpu_rays(e, {Ray{glm::dvec3(0.3, 0.5, -1.0), {0, 0, 1}}}).at(0).sem_hit == false);
}

TEST_CASE("raycast: single-voxel world, entry t by hand") {
  VoxelGrid g(glm::dvec3(0.0), 0.2);
  g.set({0, 0, 0}, 9, 7);
  // +x from 1 m before the face x = 0.
  check_ray(g, {{-1.0, 0.1, 0.1}, {1, 0, 0}}, hit({0, 0, 0}, 9, 1.0, -1));
  // -z from 1.1 m: enters the top face z = 0.2 at t = 0.9.
  check_ray(g, {{0.1, 0.1, 1.1}, {0, 0, -1}}, hit({0, 0, 0}, 9, 0.9, +3));
  // Diagonal (1, 1, 0) from (-0.1, -0.1): through the edge x = y = 0 at t = 0.1 sqrt 2; x steps
  // first (zero-length (0,-1,0)), so the voxel is entered through its -y face.
  check_ray(g, {{-0.1, -0.1, 0.1}, glm::normalize(glm::dvec3(1, 1, 0))}, hit({0, 0, 0}, 9, 0.1 * std::sqrt(2.0), -2));
  // Oblique: o = (-0.3, 0.05, 0.15), d ∝ (1, 0.1, -0.2): slab entry x = 0 at t = 0.3 / d.x.
  const glm::dvec3 d = glm::normalize(glm::dvec3(1.0, 0.1, -0.2));
  check_ray(g, {{-0.3, 0.05, 0.15}, d}, hit({0, 0, 0}, 9, 0.3 / d.x, -1));
  // t_max before the voxel: miss; t_max inside it: chord clipped.
  render::RaycastOptions o;
  o.t_max = 0.95;
  check_ray(g, {{-1.0, 0.1, 0.1}, {1, 0, 0}}, RayResult{}, o);
  o.t_max = 1.05;  // chord 0.05: label, no depth
  check_ray(g, {{-1.0, 0.1, 0.1}, {1, 0, 0}}, hit({0, 0, 0}, 9, 1.0, -1, false), o);
  // Passing beside it.
  check_ray(g, {{-1.0, 0.2, 0.1}, {1, 0, 0}}, RayResult{});
}

TEST_CASE("raycast: a camera 100 km from the origin renders the same image") {
  const int N = 500000;  // 100 km at 0.2 m
  const glm::ivec3 shift(N, -N / 2, 3);
  const VoxelGrid g0 = random_box_world(31);
  const VoxelGrid g1 = random_box_world(31, shift);
  const glm::dvec3 pos(1.234, -2.345, 1.5);
  const glm::dmat3 R = look_at(pos, glm::dvec3(5.0, 3.0, 0.0));
  const render::Camera c0 = make_camera(97, 61, 60.0, pos, R);
  const render::Camera c1 = make_camera(97, 61, 60.0, pos + glm::dvec3(shift) * 0.2, R);
  const auto a = gpu_camera(g0, c0), b = gpu_camera(g1, c1);
  REQUIRE(a.size() == b.size());
  size_t bad = 0, hits = 0;
  double max_dt = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    const bool same = a[i].sem_hit == b[i].sem_hit && a[i].depth_hit == b[i].depth_hit && a[i].class_id == b[i].class_id &&
                      a[i].normal == b[i].normal && (!a[i].sem_hit || a[i].ijk + shift == b[i].ijk);
    max_dt = std::max({max_dt, std::fabs(a[i].t_sem - b[i].t_sem), std::fabs(a[i].t_depth - b[i].t_depth)});
    if (!same) std::printf("  100 km ray %zu differs\n", i);
    bad += !same;
    hits += a[i].sem_hit;
  }
  CHECK(bad == 0);
  CHECK(max_dt <= 1e-5);
  CHECK(hits > a.size() / 3);
  // And the far render agrees with the CPU reference there.
  const Agreement ag = compare(b, render::cast_camera_cpu(g1, c1, {}, 2), 2e-4, "100km");
  CHECK(ag.disagree == 0);
  CHECK(ag.normal_only == 0);
}

TEST_CASE("raycast: eps_sem vs eps_depth, a grazing chord of 0.05 m gives a label but no depth") {
  const double vs = 0.2;
  VoxelGrid g(glm::dvec3(0.0), vs);
  g.set({0, 0, 0}, 5, 1);  // A: the corner (0.2, 0) is clipped by the ray
  for (int i = 3; i <= 6; ++i)
    for (int j = 1; j <= 6; ++j) g.set({i, j, 0}, 7, 2);  // B: x in [0.6, 1.4], y in [0.2, 1.4]
  const glm::dvec3 d = glm::normalize(glm::dvec3(1, 1, 0));
  for (double chord : {0.05, 0.005}) {
    CAPTURE(chord);
    // The line x - y = 0.2 - s crosses A's corner with chord s sqrt 2.
    const double s = chord / std::sqrt(2.0);
    const glm::dvec3 o(0.2 - s - 0.5, -0.5, 0.1);
    const double t_a = 0.5 * std::sqrt(2.0);  // enters A through y = 0
    // B by slab test: x enters at 0.6, y at 0.2 (earlier), so B's entry is the x slab.
    const double t_b = (0.6 - o.x) / d.x;
    // 0.05 >= eps_sem: label A; A's run (0.05) < eps_depth: depth from B.
    // 0.005 < eps_sem: label from B too.
    const RayResult want = chord > 0.01 ? hit({0, 0, 0}, 5, t_a, -2, true, t_b) : hit({3, 2, 0}, 7, t_b, -1, true, t_b);
    check_ray(g, {o, d}, want);
  }
}

TEST_CASE("raycast: brick skipping gives the same results as the flat GPU walk") {
  const VoxelGrid g = random_box_world(5);
  const render::Camera cam = make_camera(61, 47, 40.0, glm::dvec3(-3.0, 1.0, 1.7), look_at({-3.0, 1.0, 1.7}, {4, 2, 0}));
  const render::RaycastWorld w = render::upload_raycast_world(test::gpu_context(), g);
  render::RaycasterGpu skip(test::gpu_context(), true), flat(test::gpu_context(), false);
  const auto a = skip.cast_camera(w, cam, {}), b = flat.cast_camera(w, cam, {});
  REQUIRE(a.size() == b.size());
  size_t bad = 0, steps_a = 0, steps_b = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    bad += a[i].flags != b[i].flags || a[i].sem_class != b[i].sem_class || a[i].ijk_x != b[i].ijk_x ||
           a[i].ijk_y != b[i].ijk_y || a[i].ijk_z != b[i].ijk_z || a[i].normal != b[i].normal ||
           a[i].t_sem != b[i].t_sem || a[i].t_depth != b[i].t_depth;
    steps_a += a[i].steps;
    steps_b += b[i].steps;
  }
  CHECK(bad == 0);
  CHECK(steps_a < steps_b);
}

TEST_CASE("raycast: invalid inputs throw") {
  VoxelGrid g(glm::dvec3(0.0), 0.2);
  g.set({0, 0, 0}, 1);
  const double nan = std::nan("");
  CHECK_THROWS_AS(render::cast_rays_cpu(g, {Ray{{nan, 0, 0}, {1, 0, 0}}}, {}, 2), std::invalid_argument);
  const render::RaycastWorld w = render::upload_raycast_world(test::gpu_context(), g);
  render::RaycasterGpu rc(test::gpu_context());
  CHECK_THROWS_AS(rc.cast_rays(w, {Ray{{0, 0, 0}, {0, 0, 0}}}, {}), std::invalid_argument);
  CHECK_THROWS_AS(rc.cast_rays(w, {Ray{{1e12, 0, 0}, {1, 0, 0}}}, {}), std::invalid_argument);
  render::RaycastOptions bad;
  bad.eps_sem = -1.0;
  CHECK_THROWS_AS(rc.cast_rays(w, {Ray{}}, bad), std::invalid_argument);
  CHECK(rc.cast_rays(w, {}, {}).empty());
}
