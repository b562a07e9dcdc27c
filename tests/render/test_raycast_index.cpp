// The ray caster's occupancy index (shaders/raycast/occupancy.comp: super-brick
// words, column heights, brick blocks), its texel-buffer bindings and the exact
// pass on both routes (shaders/raycast/exact.comp in double, exact_df.comp in
// double-float) on the demo and Waymo worlds: each against the hash path, the
// flat walk and the CPU reference (engine/render/raycast_cpu.h).
#include <doctest/doctest.h>

#include "capped_context.h"
#include "gpu_test_context.h"
#include "raycast_test_util.h"
#include "gpu/shader_registry.h"
#include "gpu/spirv_reflect.h"
#include "render/buffers/trajectory.h"
#include "scene/scene_load.h"
#include "world/demo_scene.h"
#include "world/gpu_world.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"

#include <random>
#include <string>
#include <vector>

using namespace icube;
using namespace icube::raytest;
using render::Ray;
using render::RayResult;
using world::VoxelGrid;

namespace {

// Boxes and single voxels scattered over several 32³ super bricks on both sides of 0, with large empty gaps.
VoxelGrid sparse_super_world(uint32_t seed) {
  VoxelGrid g(glm::dvec3(0.3, -0.1, 0.05), 0.2);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pos(-140, 140), hz(-20, 40), size(1, 12);
  for (int b = 0; b < 60; ++b) {
    const glm::ivec3 lo(pos(rng), pos(rng), hz(rng)), sz(size(rng), size(rng), size(rng));
    for (int i = 0; i < sz.x; ++i)
      for (int j = 0; j < sz.y; ++j)
        for (int k = 0; k < sz.z; ++k) g.set(lo + glm::ivec3(i, j, k), static_cast<uint8_t>(1 + b % 20), static_cast<uint16_t>(b));
  }
  for (int v = 0; v < 200; ++v) g.set({pos(rng), pos(rng), hz(rng)}, 7, 0);
  return g;
}


}  // namespace

TEST_CASE("raycast: super-brick occupancy skipping (masks built by raycast/occupancy.comp) equals hash skipping, the flat walk and the CPU") {
  Agreement total;
  size_t steps_occ = 0, steps_hash = 0, steps_flat = 0, bad_hash = 0, bad_flat = 0;
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    CAPTURE(seed);
    const VoxelGrid g = sparse_super_world(seed);
    const render::RaycastWorld w = render::upload_raycast_world(test::gpu_context(), g);
    render::RaycasterGpu occ(test::gpu_context(), true), hash(test::gpu_context(), true),
        flat(test::gpu_context(), false);
    hash.set_occupancy(false);
    CHECK(occ.occupancy());
    std::mt19937 rng(seed * 31u);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const glm::dvec3 pos = seed % 2 ? glm::dvec3(u(rng) * 20.0, u(rng) * 20.0, 2.0 + u(rng))
                                    : glm::dvec3(45.0 * u(rng), 45.0, 15.0);  // outside the bounds
    const render::Camera cam = make_camera(73, 53, 70.0, pos, seed % 2 ? random_rotation(rng) : look_at(pos, {0, 0, 0}));
    const auto a = occ.cast_camera(w, cam, {}), b = hash.cast_camera(w, cam, {}), c = flat.cast_camera(w, cam, {});
    REQUIRE(a.size() == b.size());
    REQUIRE(a.size() == c.size());
    for (size_t i = 0; i < a.size(); ++i) {
      bad_hash += !same_hit(a[i], b[i]);
      bad_flat += !same_hit(a[i], c[i]);
      steps_occ += a[i].steps;
      steps_hash += b[i].steps;
      steps_flat += c[i].steps;
    }
    add(total, compare(from_gpu(a), render::cast_camera_cpu(g, cam, {}, 2), 1e-3 * 0.2, "super"));
  }
  std::printf("raycast super bricks: %zu rays, %zu semantic hits, steps/ray occupancy %.1f, hash %.1f, flat %.1f\n",
              total.rays, total.sem_hits, double(steps_occ) / double(total.rays), double(steps_hash) / double(total.rays),
              double(steps_flat) / double(total.rays));
  CHECK(bad_hash == 0);
  CHECK(bad_flat == 0);
  CHECK(total.sem_hits > 0);
  CHECK(static_cast<double>(total.disagree) <= 1e-5 * static_cast<double>(total.rays));
  CHECK(steps_occ < steps_hash);
  CHECK(steps_hash < steps_flat);
}

TEST_CASE("raycast: one ray caster records two worlds in one command list (occupancy masks rebuilt and grown)") {
  VoxelGrid small(glm::dvec3(0.0), 0.2);
  small.set({1, 2, 3}, 5, 9);
  const VoxelGrid big = sparse_super_world(11);
  const render::RaycastWorld ws = render::upload_raycast_world(test::gpu_context(), small);
  const render::RaycastWorld wb = render::upload_raycast_world(test::gpu_context(), big);
  const render::Camera cam = make_camera(41, 31, 70.0, glm::dvec3(0.5, -3.0, 1.0), look_at({0.5, -3.0, 1.0}, {0.3, 0.5, 0.7}));
  render::RaycasterGpu rc(test::gpu_context());
  const size_t n = size_t{41} * 31;
  gpu::Buffer hs(test::gpu_context(), n * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal, "test-hits-small");
  gpu::Buffer hb(test::gpu_context(), n * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal, "test-hits-big");
  test::gpu_context().submit_and_wait([&](gpu::CommandList& cmd) {
    rc.record_camera(cmd, ws, cam, {}, hs);
    rc.record_camera(cmd, wb, cam, {}, hb);
  });
  const auto a = gpu::download_vector<shader::RaycastHit>(test::gpu_context(), hs, n);
  const auto b = gpu::download_vector<shader::RaycastHit>(test::gpu_context(), hb, n);
  render::RaycasterGpu fresh(test::gpu_context());
  const auto a1 = fresh.cast_camera(ws, cam, {}), b1 = fresh.cast_camera(wb, cam, {});
  size_t bad = 0, hits = 0;
  for (size_t i = 0; i < n; ++i) {
    bad += !same_hit(a[i], a1[i]) + !same_hit(b[i], b1[i]);
    hits += (a[i].flags & RAYCAST_FLAG_SEM) != 0;
  }
  CHECK(bad == 0);
  CHECK(hits > 0);
}

TEST_CASE("raycast: occupancy masks are kept between records of one world and rebuilt after a revision bump") {
  const VoxelGrid g = sparse_super_world(5);
  // The same bricks with voxels added in other octants (x mirrored by 4 inside the brick): masks
  // kept from g would skip the new voxels, so a stale cache changes the hits.
  VoxelGrid g2 = g;
  g.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    const glm::ivec3 m((ijk.x & ~7) | ((ijk.x & 7) ^ 4), ijk.y, ijk.z);
    if (g.get(m).class_id == 0) g2.set(m, v.class_id, v.instance);
  });
  const world::GpuWorldHost host2 = world::build_gpu_world_host(g2);
  render::RaycastWorld w = render::upload_raycast_world(test::gpu_context(), g);
  REQUIRE(w.id != 0);
  REQUIRE(host2.bricks.size() * sizeof(uint32_t) == w.gpu.brick_data.size());  // same bricks, same records
  const render::Camera cam = make_camera(67, 45, 70.0, glm::dvec3(-30.0, 20.0, 8.0), look_at({-30.0, 20.0, 8.0}, {0, 0, 0}));
  render::RaycasterGpu rc(test::gpu_context());
  const auto a = rc.cast_camera(w, cam, {});
  CHECK(rc.occupancy_builds() == 1);
  const auto a2 = rc.cast_camera(w, cam, {});
  CHECK(rc.occupancy_builds() == 1);  // kept
  size_t bad = 0;
  for (size_t i = 0; i < a.size(); ++i) bad += !same_hit(a[i], a2[i]);
  CHECK(bad == 0);
  const Agreement before = compare(from_gpu(a), render::cast_camera_cpu(g, cam, {}, 2), 1e-3 * 0.2, "cache g");
  CHECK(static_cast<double>(before.disagree) <= 1e-5 * static_cast<double>(before.rays));

  gpu::upload(test::gpu_context(), w.gpu.brick_data, host2.bricks.data(), host2.bricks.size() * sizeof(uint32_t));
  ++w.revision;
  const auto b = rc.cast_camera(w, cam, {});
  CHECK(rc.occupancy_builds() == 2);  // rebuilt
  const std::vector<RayResult> cpu2 = render::cast_camera_cpu(g2, cam, {}, 2);
  const Agreement after = compare(from_gpu(b), cpu2, 1e-3 * 0.2, "cache g2");
  CHECK(static_cast<double>(after.disagree) <= 1e-5 * static_cast<double>(after.rays));
  size_t changed = 0;
  for (size_t i = 0; i < a.size(); ++i) changed += !same_hit(a[i], b[i]);
  CHECK(changed > 0);  // the new voxels are seen
  // Another world in between evicts the masks; coming back rebuilds them.
  const render::RaycastWorld other = render::upload_raycast_world(test::gpu_context(), sparse_super_world(6));
  (void)rc.cast_camera(other, cam, {});
  (void)rc.cast_camera(w, cam, {});
  CHECK(rc.occupancy_builds() == 4);
}

namespace {

// Terrain of brick and super-brick columns with different heights (column tops at brick
// boundaries, inside bricks and at z < 0), pillars and overhangs, for the column-height skips.
// Origin and voxel size are exact in binary, so rays can start exactly on voxel faces.
VoxelGrid column_world() {
  VoxelGrid g(glm::dvec3(-3.0, 1.5, -0.75), 0.25);
  for (int i = -70; i < 70; ++i)
    for (int j = -70; j < 70; ++j) {
      const int h = ((i >> 3) * 7 + (j >> 3) * 3) % 11 - 3;  // per brick column: -3 .. 7
      for (int k = -4; k <= h; ++k) g.set({i, j, k}, static_cast<uint8_t>(k == h ? 17 : 20), 0);
    }
  for (int p = 0; p < 12; ++p)  // pillars up to z 40 (other super bricks) and overhang slabs at z 30
    for (int k = 0; k < 10 + 3 * p; ++k) g.set({-60 + 11 * p, 5 * p - 30, k}, 8, static_cast<uint16_t>(p + 1));
  for (int i = 20; i < 40; ++i)
    for (int j = -10; j < 10; ++j) g.set({i, j, 30}, 9, 99);
  return g;
}

}  // namespace

TEST_CASE("raycast: column-height skips (rays above brick and super-brick column tops) equal the flat walk and the CPU") {
  const VoxelGrid g = column_world();
  const render::RaycastWorld w = render::upload_raycast_world(test::gpu_context(), g);
  render::RaycasterGpu occ(test::gpu_context(), true), hash(test::gpu_context(), true), flat(test::gpu_context(), false);
  hash.set_occupancy(false);
  std::vector<Ray> rays;
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double vs = 0.25;
  const glm::dvec3 o = g.origin();
  for (int n = 0; n < 3000; ++n) {  // grazing rays just above the terrain, from inside and outside the bounds
    const glm::dvec3 p(o.x + 12.0 * u(rng), o.y + 12.0 * u(rng), o.z + vs * (9.0 + 3.0 * u(rng)));
    rays.push_back({p, glm::normalize(glm::dvec3(u(rng), u(rng), -0.02 + 0.03 * u(rng)))});
  }
  for (int i = -60; i < 60; i += 7)
    for (int j = -60; j < 60; j += 5) {
      const int h = ((i >> 3) * 7 + (j >> 3) * 3) % 11 - 3;
      const glm::dvec3 top = o + vs * glm::dvec3(i + 0.5, j + 0.5, h + 1);  // exactly on the column top plane
      rays.push_back({top, {0, 0, -1}});                                 // axis-parallel down onto the top
      rays.push_back({top + glm::dvec3(0, 0, 3.0), {0, 0, -1}});
      rays.push_back({top, glm::normalize(glm::dvec3(1, 0.3, 0))});       // along the top plane
      rays.push_back({top, glm::normalize(glm::dvec3(-1, 0, 0))});
      rays.push_back({top + glm::dvec3(0, 0, 9.0), glm::normalize(glm::dvec3(0.7, -0.4, -0.2))});
      rays.push_back({o + vs * glm::dvec3(i & ~7, j & ~7, h + 1), glm::normalize(glm::dvec3(1, 1, -1))});  // column corner
    }
  const auto a = occ.cast_rays(w, rays, {}), b = hash.cast_rays(w, rays, {}), c = flat.cast_rays(w, rays, {});
  size_t bad_hash = 0, bad_flat = 0, steps_occ = 0, steps_hash = 0, hits = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (!same_hit(a[i], c[i]) && bad_flat++ < 5)
      std::printf("column ray %zu: occupancy flags %u voxel (%d, %d, %d) t %.6f vs flat flags %u voxel (%d, %d, %d) t %.6f\n", i,
                  a[i].flags, a[i].ijk_x, a[i].ijk_y, a[i].ijk_z, double(a[i].t_sem), c[i].flags, c[i].ijk_x, c[i].ijk_y,
                  c[i].ijk_z, double(c[i].t_sem));
    bad_hash += !same_hit(a[i], b[i]);
    steps_occ += a[i].steps;
    steps_hash += b[i].steps;
    hits += (a[i].flags & RAYCAST_FLAG_SEM) != 0;
  }
  std::printf("raycast columns: %zu rays, %zu hits, steps/ray occupancy %.1f, hash %.1f\n", a.size(), hits,
              double(steps_occ) / double(a.size()), double(steps_hash) / double(a.size()));
  CHECK(bad_flat == 0);
  CHECK(bad_hash == 0);
  CHECK(hits > a.size() / 4);
  CHECK(2 * steps_occ < steps_hash);  // the column skips pay on a terrain
  const Agreement agree = compare(from_gpu(a), render::cast_rays_cpu(g, rays, {}, 2), 1e-3 * 0.2, "columns");
  CHECK(static_cast<double>(agree.disagree) <= 1e-5 * static_cast<double>(agree.rays));
}

TEST_CASE("raycast: the occupancy index and brick words are texel-buffer bindings, checked at dispatch and working with pooled descriptor sets") {
  const gpu::EmbeddedShader& sh = gpu::find_shader("raycast/cast");
  const gpu::ShaderReflection r = gpu::reflect_spirv(sh.words, sh.word_count, sh.name);
  // The world itself (hash table, brick words), the occupancy index and its mask level are texel
  // buffers; rays, hits and the near list storage buffers (bound in windows of rays).
  REQUIRE(r.bindings.size() == 7);
  CHECK(r.bindings[0].binding == 0);
  CHECK(r.bindings[0].type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER);
  CHECK(r.bindings[1].type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
  CHECK(r.bindings[2].type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
  CHECK(r.bindings[3].type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER);
  CHECK(r.bindings[4].type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER);
  CHECK(r.bindings[5].type == VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
  CHECK(r.bindings[6].binding == 8);  // the mask level of the index
  CHECK(r.bindings[6].type == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER);

  gpu::Context& ctx = test::gpu_context();
  gpu::Buffer buf(ctx, 256, gpu::MemoryUsage::DeviceLocal, "texel-check");
  gpu::Program& c = ctx.program("raycast/cast", gpu::SpecConstants{}.set(0, 64u));
  shader::RaycastParams p{};
  p.n = 1;
  const gpu::BufferBinding t32 = buf.texel_binding(VK_FORMAT_R32_UINT), t128 = buf.texel_binding(VK_FORMAT_R32G32B32A32_UINT);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) {
    CHECK_THROWS_WITH_AS(cmd.dispatch(c, {1}, p, {buf.binding(), buf.binding(), buf.binding(), t32, t32, buf.binding(), t32}),
                         doctest::Contains("needs Buffer::texel_binding"), std::logic_error);
    CHECK_THROWS_WITH_AS(cmd.dispatch(c, {1}, p, {t128, t32, buf.binding(), t32, t32, buf.binding(), t32}),
                         doctest::Contains("not a texel buffer"), std::logic_error);
    CHECK_THROWS_WITH_AS(cmd.dispatch(c, {1}, p, {t128, buf.binding(), buf.binding(), buf.texel_binding(VK_FORMAT_R32_UINT, 4, 64),
                                                  t32, buf.binding(), t32}),
                         doctest::Contains("is not aligned"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(cmd.dispatch(c, {1}, p, {buf.texel_binding(VK_FORMAT_R32G32B32A32_UINT, 0, 24), buf.binding(),
                                                  buf.binding(), t32, t32, buf.binding(), t32}),
                         doctest::Contains("not a multiple of its 16-byte texels"), std::invalid_argument);
  });

  // The same casts through pooled descriptor sets (texel-buffer descriptors written with
  // vkUpdateDescriptorSets) as through push descriptors.
  gpu::ContextOptions opts = gpu::ContextOptions::from_env();
  opts.disable_push_descriptors = true;
  auto pooled = test::make_validated_context(opts);
  REQUIRE_FALSE(pooled->program("raycast/occupancy").uses_push_descriptors());
  const VoxelGrid g = column_world();
  const render::RaycastWorld wp = render::upload_raycast_world(*pooled, g);
  const render::RaycastWorld wq = render::upload_raycast_world(ctx, g);
  render::RaycasterGpu rp(*pooled), rq(ctx);
  const render::Camera cam = make_camera(61, 37, 50.0, glm::dvec3(-2.0, 3.0, 1.5), look_at({-2.0, 3.0, 1.5}, {8.0, 6.0, -0.5}));
  const auto a = rp.cast_camera(wp, cam, {}), b = rq.cast_camera(wq, cam, {});
  REQUIRE(a.size() == b.size());
  size_t bad = 0, hits = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    bad += !same_hit(a[i], b[i]);
    hits += (a[i].flags & RAYCAST_FLAG_SEM) != 0;
  }
  CHECK(bad == 0);
  CHECK(hits > a.size() / 2);
}

namespace {

// The Waymo FRONT 832x480 camera at the middle of the scene's ego track (the benchmark's frame).
render::Camera middle_ego_camera(const scene::Scene& sc) {
  const scene::Camera preset = render::camera_preset("waymo-front-480p");
  const render::Trajectory tr = render::ego_trajectory(sc, preset);
  REQUIRE(tr.size() > 0);
  render::Camera cam;
  cam.K = render::intrinsics_of(preset);
  cam.c2w = tr.c2w[tr.size() / 2];
  return cam;
}

VoxelGrid procedural_world(const scene::Scene& sc, world::PlanMode mode) {
  const world::ProceduralPrior prior(sc);
  world::WorldBuildOptions o;
  o.mode = mode;
  o.threads = 2;
  return world::build_world(sc, prior, o).world;
}

// The exact pass on both routes — double chords (raycast/exact.comp, where the device has
// shaderFloat64) and double-float chords (raycast/exact_df.comp, forced) — and the float pass
// alone, each against the CPU reference: the exact routes within the 1e-5 budget, the flag
// internal to the passes, every ray the exact pass changes one the float pass decided
// differently from the CPU, and (with shaderFloat64) both routes giving the same hits.
void check_exact_routes(const char* name, const VoxelGrid& g, const render::Camera& cam) {
  gpu::Context& ctx = test::gpu_context();
  const render::RaycastWorld w = render::upload_raycast_world(ctx, g);
  render::RaycasterGpu fast(ctx), dbl(ctx), df(ctx);
  fast.set_exact(false);
  df.set_exact_float_only(true);
  REQUIRE(df.exact());
  REQUIRE(df.exact_float_only());
  REQUIRE_FALSE(fast.exact());
  const bool has_f64 = !dbl.exact_float_only();
  const std::vector<RayResult> cpu = render::cast_camera_cpu(g, cam, {}, 2);
  const auto b = fast.cast_camera(w, cam, {});
  const Agreement fa = compare(from_gpu(b), cpu, 1e-3 * 0.2, "float");
  std::vector<shader::RaycastHit> dbl_hits;
  for (render::RaycasterGpu* rc : {&dbl, &df}) {
    if (rc == &dbl && !has_f64) continue;
    const std::string route = rc == &df ? "double-float" : "double";
    CAPTURE(route);
    const auto a = rc->cast_camera(w, cam, {});
    const Agreement ea = compare(from_gpu(a), cpu, 1e-3 * 0.2, route.c_str());
    size_t near_left = 0, changed = 0, changed_wrong = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      near_left += (a[i].flags & RAYCAST_FLAG_NEAR) != 0 || (b[i].flags & RAYCAST_FLAG_NEAR) != 0;
      if (!same_hit(a[i], b[i])) {
        ++changed;
        const Agreement one = compare({from_gpu(b[i])}, {cpu[i]}, 1e-3 * 0.2, "float (changed ray)");
        changed_wrong += one.disagree;
      }
    }
    MESSAGE(std::string(name) << " " << cam.K.width << "x" << cam.K.height << ": " << route << " exact pass " << ea.disagree
                 << " of " << ea.rays << " rays differ from the CPU, float pass alone " << fa.disagree << "; " << changed
                 << " rays changed by the exact pass");
    CHECK(near_left == 0);  // the flag is internal to the two passes
    CHECK(static_cast<double>(ea.disagree) <= 1e-5 * static_cast<double>(ea.rays));
    CHECK(ea.disagree <= fa.disagree);
    CHECK(changed_wrong == changed);  // the exact pass changes only rays the float decision got wrong
    CHECK(fa.disagree - ea.disagree == changed);
    if (rc == &dbl) {
      dbl_hits = a;
    } else if (has_f64) {
      size_t differ = 0;
      for (size_t i = 0; i < a.size(); ++i) differ += !same_hit(a[i], dbl_hits[i]);
      CHECK(differ == 0);  // double-float chords decide as double ones
    }
  }
}

}  // namespace

TEST_CASE("raycast: the exact pass, double (raycast/exact.comp) and float-only (raycast/exact_df.comp), decides near-threshold semantic chords as the CPU does on the demo world") {
  // The benchmark's frame, where the float pass alone decides 7 rays differently from the CPU.
  const scene::Scene sc = world::make_demo_scene();
  check_exact_routes("demo world", procedural_world(sc, world::PlanMode::Trajectory), middle_ego_camera(sc));
}

TEST_CASE("raycast: the exact pass on both routes on the real Waymo world") {
  const std::string path = test::test_data_file("maps/waymo/motion_data_one_scenario.tfrecord");
  if (path.empty()) return;  // skipped (or failed under ICUBE_REQUIRE_DATA=1)
  const scene::Scene sc = scene::load_scene(path);
  check_exact_routes("waymo world", procedural_world(sc, world::PlanMode::Blocks), middle_ego_camera(sc));
}

TEST_CASE("raycast: casts over one storage binding run in windows of rays with the same hits (bands of tile rows, rows, ray lists, hash fallback)") {
  // The demo world's ego frame at 832x480 (19 MB of hits, 5.3 MB occupancy index) under capped
  // bindings: 8 MiB (the index fits; bands of 26 tile rows), 1 MiB (the index does not: the hash-table
  // pipeline; bands of 3 tile rows) and 64 KiB (a tile row does not fit: windows of 1,365 rays
  // without tiles). Every hit, the exact pass's included, equals the uncapped cast's.
  const scene::Scene sc = world::make_demo_scene();
  const VoxelGrid g = procedural_world(sc, world::PlanMode::Trajectory);
  const render::Camera cam = middle_ego_camera(sc);
  gpu::Context& ctx = test::gpu_context();
  render::RaycasterGpu whole(ctx);
  const render::RaycastWorld ww = render::upload_raycast_world(ctx, g);
  const auto want = whole.cast_camera(ww, cam, {});
  std::mt19937 rng(5);
  std::normal_distribution<double> nd;
  std::vector<render::Ray> rays(20011);
  for (render::Ray& r : rays) {
    r.origin = render::camera_position(cam) + glm::dvec3(nd(rng), nd(rng), 0.2 * nd(rng));
    r.dir = glm::dvec3(nd(rng), nd(rng), 0.3 * nd(rng) - 0.2);
  }
  const auto want_rays = whole.cast_rays(ww, rays, {});
  for (const uint64_t cap : {uint64_t{8} << 20, uint64_t{1} << 20, uint64_t{64} << 10}) {
    CAPTURE(cap);
    gpu::Context& capped = test::capped_gpu_context(cap);
    render::RaycasterGpu rc(capped);
    const render::RaycastWorld w = render::upload_raycast_world(capped, g);
    const auto got = rc.cast_camera(w, cam, {});
    CHECK(rc.occupancy_builds() == (cap >= (8u << 20) ? 1u : 0u));
    REQUIRE(got.size() == want.size());
    size_t bad = 0;
    for (size_t i = 0; i < got.size(); ++i) bad += !same_hit(got[i], want[i]);
    CHECK(bad == 0);
    const auto got_rays = rc.cast_rays(w, rays, {});
    size_t bad_rays = 0, sem = 0;
    for (size_t i = 0; i < got_rays.size(); ++i) {
      bad_rays += !same_hit(got_rays[i], want_rays[i]);
      sem += (got_rays[i].flags & RAYCAST_FLAG_SEM) != 0;
    }
    CHECK(bad_rays == 0);
    CHECK(sem > rays.size() / 4);
  }
}
