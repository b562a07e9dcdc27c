// shaders/view_shade.comp through viewer::ViewRenderer (ray caster + shading,
// headless): the semantic mode against a CPU reference (the CPU ray caster's
// class per pixel through the guidance palette, sky = palette entry 8), and
// the instance mode's background rule (no hit = black), on a hand-built world.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "render/raycast_cpu.h"
#include "render/raycast_gpu.h"
#include "view_renderer.h"
#include "world/semantics.h"
#include "world/voxel_grid.h"

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
