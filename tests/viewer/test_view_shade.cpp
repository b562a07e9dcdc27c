// shaders/view/shade.comp through viewer::ViewRenderer (ray caster + shading,
// headless): the semantic mode against a CPU reference (the CPU ray caster's
// class per pixel through the guidance palette, sky = palette entry 8), and
// the instance mode's background rule (no hit = black), on a hand-built world;
// the shaded mode's sun shadows and ambient occlusion (shaders/view/rays.comp
// + the ray caster's ray-list mode) against the same lighting with CPU rays
// (render::cast_ray_cpu) on a box floating over a floor, and the other modes
// unchanged by them.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "render/raycast_cpu.h"
#include "render/raycast_gpu.h"
#include "view_renderer.h"
#include "world/semantics.h"
#include "world/voxel_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

using namespace icube;

namespace {

// A floor of road and a wall striped in three classes, seen from 1.5 m above the floor.
world::VoxelGrid striped_world() {
  world::VoxelGrid g;
  for (int x = -40; x < 40; ++x)
    for (int y = -5; y < 60; ++y) g.set({x, y, -1}, 18);
  const uint8_t stripes[3] = {14, 15, 22};
  for (int x = -40; x < 40; ++x)
    for (int z = 0; z < 30; ++z) g.set({x, 60, z}, stripes[(x + 40) / 8 % 3], static_cast<uint16_t>(x > 20 ? 7 : 0));
  return g;
}

render::Camera looking_north(uint32_t w, uint32_t h) {
  render::Camera cam;
  cam.K = {0.8 * w, 0.8 * w, 0.5 * w - 0.3, 0.5 * h + 0.7, w, h};
  // OpenCV axes: x right = world +x, y down = world -z, z forward = world +y.
  cam.c2w = glm::dmat4(glm::dvec4(1, 0, 0, 0), glm::dvec4(0, 0, -1, 0), glm::dvec4(0, 1, 0, 0),
                       glm::dvec4(0.13, 0.0, 1.5, 1));
  return cam;
}

uint32_t pack(const std::array<uint8_t, 3>& c) { return c[0] | (c[1] << 8) | (c[2] << 16) | (0xFFu << 24); }

}  // namespace

TEST_CASE("view_shade: semantic mode equals the palette of the CPU ray caster's hits") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = striped_world();
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, g);
  const render::Camera cam = looking_north(97, 61);
  viewer::ViewRenderer vr(ctx);
  viewer::ShadeSettings s;
  s.mode = viewer::RenderMode::Semantic;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { vr.record(cmd, rw, cam, s); });
  const std::vector<uint8_t> rgba = vr.download_rgba();
  REQUIRE(rgba.size() == size_t{97} * 61 * 4);

  render::RaycastOptions ro;
  ro.t_max = s.max_distance;
  const std::vector<render::RayResult> ref = render::cast_camera_cpu(g, cam, ro, 2);
  size_t bad = 0, sky = 0, hits = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    const uint8_t cls = ref[i].sem_hit ? ref[i].class_id : 0;
    (cls ? hits : sky) += 1;
    uint32_t got = 0;
    for (int c = 0; c < 4; ++c) got |= uint32_t{rgba[4 * i + static_cast<size_t>(c)]} << (8 * c);
    const uint32_t want = pack(world::class_color(cls));
    if (got != want && bad++ < 5) MESSAGE("pixel " << i << ": got " << std::hex << got << " want " << want);
  }
  CHECK(bad == 0);
  CHECK(hits > 1000);
  CHECK(sky > 100);
}

TEST_CASE("view_shade: instance mode is black where nothing is hit and differs for instances") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = striped_world();
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, g);
  const render::Camera cam = looking_north(64, 40);
  viewer::ViewRenderer vr(ctx);
  viewer::ShadeSettings s;
  s.mode = viewer::RenderMode::Instance;
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { vr.record(cmd, rw, cam, s); });
  const std::vector<uint8_t> rgba = vr.download_rgba();
  render::RaycastOptions ro;
  ro.t_max = s.max_distance;
  const std::vector<render::RayResult> ref = render::cast_camera_cpu(g, cam, ro, 2);
  size_t misses_black = 0, misses = 0, inst = 0, inst_bright = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    const uint8_t* p = &rgba[4 * i];
    if (!ref[i].sem_hit) {
      ++misses;
      misses_black += p[0] == 0 && p[1] == 0 && p[2] == 0;
    } else if (ref[i].instance > 0) {
      ++inst;
      // An instance colour, never the dimmed (0.3 x palette) background of non-instance voxels.
      const auto pal = world::class_color(ref[i].class_id);
      inst_bright += !(p[0] == uint8_t(0.3 * pal[0] + 0.5) && p[1] == uint8_t(0.3 * pal[1] + 0.5));
    }
  }
  CHECK(misses > 0);
  CHECK(misses_black == misses);
  CHECK(inst > 0);
  CHECK(inst_bright == inst);
}

// ---- shadows and ambient occlusion ----------------------------------------------------

namespace {

// Road floor (top at z = 0), a building box floating 2..5 m above it (it casts a shadow on the
// floor) and a wall standing on the floor at y = 16 m (ambient occlusion in the corner).
world::VoxelGrid box_world() {
  world::VoxelGrid g;
  for (int x = -60; x < 60; ++x)
    for (int y = -5; y < 90; ++y) g.set({x, y, -1}, 18);
  for (int x = -30; x < 30; ++x)
    for (int y = 40; y < 60; ++y)
      for (int z = 10; z < 25; ++z) g.set({x, y, z}, 14);
  for (int x = -60; x < 60; ++x)
    for (int z = 0; z < 20; ++z) g.set({x, 80, z}, 15);
  return g;
}

// A camera 4 m above the floor looking north and 20 degrees down.
render::Camera looking_down(uint32_t w, uint32_t h) {
  render::Camera cam;
  cam.K = {0.7 * w, 0.7 * w, 0.5 * w + 0.2, 0.5 * h - 0.4, w, h};
  const double a = 20.0 * 3.14159265358979 / 180.0;
  const glm::dvec3 fwd(0.0, std::cos(a), -std::sin(a)), right(1.0, 0.0, 0.0);
  const glm::dvec3 down = glm::cross(fwd, right);  // OpenCV y: z forward x right -> y = z × x
  cam.c2w = glm::dmat4(glm::dvec4(right, 0), glm::dvec4(down, 0), glm::dvec4(fwd, 0), glm::dvec4(0.31, 0.07, 4.0, 1));
  return cam;
}

struct CpuShade {
  std::vector<int> lit;  // per pixel: -1 no hit; else the expected RGBA (packed) with the visibility below
  std::vector<uint32_t> rgba;
  std::vector<uint8_t> shadowed;
  std::vector<uint32_t> ao_blocked;
  std::vector<int> normal;  // the camera hit's entry face
};

// view/shade.comp's shaded mode (fog 0) with the visibility of view/rays.comp from CPU rays
// (render::cast_ray_cpu): origin on the entry face of the hit voxel, sun / ao_direction rays.
CpuShade shade_cpu(const world::VoxelGrid& g, const render::Camera& cam, const viewer::ShadeSettings& s) {
  render::RaycastOptions ro;
  ro.t_max = s.max_distance;
  const std::vector<render::RayResult> cam_hits = render::cast_camera_cpu(g, cam, ro, 2);
  const world::IjkBounds bounds = render::raycast_bounds(g);
  const glm::dvec3 sun = glm::dvec3(glm::vec3(glm::normalize(s.sun_dir)));  // the kernels' float sun
  const double vs = g.voxel_size();
  const glm::dmat3 R(cam.c2w);
  const glm::dvec3 eye(cam.c2w[3]);
  const uint32_t W = cam.K.width;
  CpuShade out;
  const size_t n = cam_hits.size();
  out.rgba.assign(n, 0);
  out.shadowed.assign(n, 0);
  out.ao_blocked.assign(n, 0);
  out.lit.assign(n, -1);
  out.normal.assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const render::RayResult& r = cam_hits[i];
    if (!r.sem_hit || r.normal == 0) continue;
    const double u = static_cast<double>(i % W), v = static_cast<double>(i / W);
    const glm::dvec3 d = glm::normalize(R * glm::dvec3((u - cam.K.cx) / cam.K.fx, (v - cam.K.cy) / cam.K.fy, 1.0));
    const int a = std::abs(r.normal) - 1;
    const double sg = r.normal > 0 ? 1.0 : -1.0;
    glm::dvec3 nrm(0.0);
    nrm[a] = sg;
    const glm::dvec3 q = (eye + r.t_sem * d - g.origin()) / vs;
    glm::dvec3 org = glm::clamp(q, glm::dvec3(r.ijk) + 1e-3, glm::dvec3(r.ijk) + (1.0 - 1e-3));
    org[a] = (sg > 0 ? r.ijk[a] + 1 : r.ijk[a]) + sg * 2e-3;
    const glm::dvec3 o = g.origin() + org * vs;
    const double lambert = std::max(0.0, glm::dot(nrm, sun));
    if (s.shadows && lambert > 0.0) {
      render::RaycastOptions so;
      so.t_max = std::min(s.shadow_distance, s.max_distance);
      out.shadowed[i] = render::cast_ray_cpu(g, bounds, {o, sun}, so).sem_hit;
    }
    for (int k = 0; k < s.ao_samples; ++k) {
      render::RaycastOptions ao;
      ao.t_max = s.ao_radius;
      const glm::dvec3 dir = viewer::ao_direction(static_cast<uint32_t>(i % W), static_cast<uint32_t>(i / W),
                                                  static_cast<uint32_t>(k), static_cast<uint32_t>(s.ao_samples), r.normal);
      out.ao_blocked[i] += render::cast_ray_cpu(g, bounds, {o, dir}, ao).sem_hit;
    }
    const double sky_light = 0.5 + 0.5 * nrm.z;
    const double aof = s.ao_samples > 0 ? 1.0 - s.ao_strength / s.ao_samples * out.ao_blocked[i] : 1.0;
    const double term = s.ambient * (0.6 + 0.4 * sky_light) * aof + (1.0 - s.ambient) * lambert * (out.shadowed[i] ? 0.0 : 1.0);
    const auto pal = world::class_color(r.class_id);
    uint32_t px = 0xFFu << 24;
    for (int c = 0; c < 3; ++c)
      px |= static_cast<uint32_t>(std::lround(std::clamp(pal[static_cast<size_t>(c)] / 255.0 * term, 0.0, 1.0) * 255.0)) << (8 * c);
    out.rgba[i] = px;
    out.lit[i] = 1;
    out.normal[i] = r.normal;
  }
  return out;
}

std::vector<uint32_t> render_gpu(gpu::Context& ctx, const render::RaycastWorld& rw, const render::Camera& cam,
                                 const viewer::ShadeSettings& s) {
  viewer::ViewRenderer vr(ctx);
  ctx.submit_and_wait([&](gpu::CommandList& cmd) { vr.record(cmd, rw, cam, s); });
  const std::vector<uint8_t> px = vr.download_rgba();
  std::vector<uint32_t> out(px.size() / 4);
  for (size_t i = 0; i < out.size(); ++i)
    for (int c = 0; c < 4; ++c) out[i] |= uint32_t{px[4 * i + static_cast<size_t>(c)]} << (8 * c);
  return out;
}

int max_channel_diff(uint32_t a, uint32_t b) {
  int m = 0;
  for (int c = 0; c < 3; ++c) m = std::max(m, std::abs(int((a >> (8 * c)) & 255u) - int((b >> (8 * c)) & 255u)));
  return m;
}

}  // namespace

TEST_CASE("view_shade: sun shadows darken exactly the pixels the CPU finds in shadow, by the lighting factor") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = box_world();
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, g);
  const render::Camera cam = looking_down(131, 77);
  viewer::ShadeSettings s;
  s.mode = viewer::RenderMode::Shaded;
  s.fog_density = 0.0;
  const std::vector<uint32_t> off = render_gpu(ctx, rw, cam, s);
  s.shadows = true;
  const std::vector<uint32_t> on = render_gpu(ctx, rw, cam, s);
  const CpuShade ref = shade_cpu(g, cam, s);
  const glm::dvec3 sun = glm::dvec3(glm::vec3(glm::normalize(s.sun_dir)));
  size_t hits = 0, shadowed = 0, floor_shadowed = 0, bad = 0, factor_bad = 0, changed_unshadowed = 0;
  for (size_t i = 0; i < on.size(); ++i) {
    if (ref.lit[i] < 0) continue;
    ++hits;
    if (max_channel_diff(on[i], ref.rgba[i]) > 1 && bad++ < 5)
      MESSAGE("pixel " << i << ": gpu " << std::hex << on[i] << " cpu " << ref.rgba[i] << std::dec
                       << " cpu shadowed " << int(ref.shadowed[i]));
    if (!ref.shadowed[i]) {
      changed_unshadowed += on[i] != off[i];
      continue;
    }
    ++shadowed;
    if (ref.normal[i] != 3) continue;
    // Floor pixels (normal +z): lit = a·1.0 + (1-a)·sun_z, shadowed = a·1.0 (times the class colour).
    ++floor_shadowed;
    const double factor = s.ambient / (s.ambient + (1.0 - s.ambient) * sun.z);
    bool ok = true;
    for (int c = 0; c < 3; ++c) {
      const double lit = double((off[i] >> (8 * c)) & 255u), dark = double((on[i] >> (8 * c)) & 255u);
      ok = ok && std::fabs(dark - lit * factor) <= 1.5;
    }
    if (!ok && factor_bad++ < 5)
      MESSAGE("floor pixel " << i << ": shadowed " << std::hex << on[i] << " lit " << off[i] << std::dec << " factor " << factor);
  }
  MESSAGE(hits << " hit pixels, " << shadowed << " in shadow (" << floor_shadowed << " on the floor), " << bad
               << " differ from the CPU by > 1");
  CHECK(shadowed > 200);
  CHECK(hits > 5000);
  CHECK(bad <= hits / 200);  // shadow-edge pixels where float and double rays part (<= 0.5 %)
  CHECK(floor_shadowed > 200);
  CHECK(factor_bad == 0);
  CHECK(changed_unshadowed <= hits / 200);
}

TEST_CASE("view_shade: ambient occlusion matches the CPU rays of the same pattern; other modes are unchanged") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = box_world();
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, g);
  const render::Camera cam = looking_down(96, 57);
  viewer::ShadeSettings s;
  s.mode = viewer::RenderMode::Shaded;
  s.fog_density = 0.0;
  s.shadows = true;
  s.ao_samples = 5;
  s.ao_radius = 1.2;
  const std::vector<uint32_t> gpu_px = render_gpu(ctx, rw, cam, s);
  const CpuShade ref = shade_cpu(g, cam, s);
  size_t hits = 0, occluded = 0, bad = 0;
  for (size_t i = 0; i < gpu_px.size(); ++i) {
    if (ref.lit[i] < 0) continue;
    ++hits;
    occluded += ref.ao_blocked[i] > 0;
    if (max_channel_diff(gpu_px[i], ref.rgba[i]) > 1 && bad++ < 5)
      MESSAGE("pixel " << i << ": gpu " << std::hex << gpu_px[i] << " cpu " << ref.rgba[i] << std::dec << " ao "
                       << ref.ao_blocked[i]);
  }
  MESSAGE(hits << " hit pixels, " << occluded << " with AO rays blocked, " << bad << " differ from the CPU by > 1");
  CHECK(occluded > 100);
  CHECK(bad <= hits / 100);

  // Semantic and depth pictures do not change with shadows / AO on.
  for (viewer::RenderMode m : {viewer::RenderMode::Semantic, viewer::RenderMode::Depth, viewer::RenderMode::Instance}) {
    viewer::ShadeSettings plain;
    plain.mode = m;
    viewer::ShadeSettings extra = s;
    extra.mode = m;
    CHECK(render_gpu(ctx, rw, cam, plain) == render_gpu(ctx, rw, cam, extra));
  }
}
