// The procedural appearance renderer (engine/render/appearance/): the GPU
// frame against the CPU reference (double ray caster, VoxelGrid probes, the
// same shading model) at odd sizes under every look; determinism and the seed;
// the same frame 100 km from the origin; detail fixed to the world (a ground
// point seen from two cameras keeps its colour); shadows and AO darken;
// night darker than day and fog lowering far contrast, measured.
#include <doctest/doctest.h>

#include "gpu_test_context.h"
#include "test_world_util.h"

#include "render/appearance/appearance_cpu.h"
#include "render/appearance/appearance_gpu.h"
#include "render/appearance/frames_render.h"
#include "render/appearance/lighting.h"
#include "render/raycast_cpu.h"
#include "scene/frames.h"
#include "world/demo_scene.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace icube;

namespace {

constexpr uint8_t kBuilding = 14, kVegetation = 15, kTrunk = 16, kRoad = 18, kSidewalk = 22, kPole = 10, kCar = 1;

// A block of town on the world lattice: sidewalk ground with a road strip, a building, a tree, a
// pole (a street lamp at night) and a car, all in ijk, so any origin gives the same voxels.
world::VoxelGrid town(const glm::dvec3& origin) {
  world::VoxelGrid g(origin, 0.2);
  for (int x = -60; x < 140; ++x)
    for (int y = -60; y < 60; ++y) g.set({x, y, 0}, (y >= -12 && y < 12) ? kRoad : kSidewalk);
  for (int x = 40; x < 70; ++x)
    for (int y = 20; y < 45; ++y)
      for (int z = 1; z < 60; ++z) g.set({x, y, z}, kBuilding);
  for (int z = 1; z < 18; ++z) g.set({0, 25, z}, kTrunk), g.set({1, 25, z}, kTrunk);
  for (int x = -10; x <= 10; ++x)
    for (int y = 15; y <= 35; ++y)
      for (int z = 14; z <= 34; ++z)
        if ((x * x + (y - 25) * (y - 25) + (z - 24) * (z - 24)) <= 100) g.set({x, y, z}, kVegetation);
  for (int z = 1; z < 35; ++z) g.set({20, -16, z}, kPole);
  for (int x = 10; x < 32; ++x)
    for (int y = -8; y < 1; ++y)
      for (int z = 1; z < 8; ++z) g.set({x, y, z}, kCar, 10001);
  return g;
}

// OpenCV camera-to-world looking from eye to target (z up world).
glm::dmat4 look_at(const glm::dvec3& eye, const glm::dvec3& target) {
  const glm::dvec3 f = glm::normalize(target - eye);
  const glm::dvec3 r = glm::normalize(glm::cross(f, glm::dvec3(0, 0, 1)));
  const glm::dvec3 d = glm::cross(f, r);
  glm::dmat4 m(1.0);
  m[0] = glm::dvec4(r, 0);
  m[1] = glm::dvec4(d, 0);
  m[2] = glm::dvec4(f, 0);
  m[3] = glm::dvec4(eye, 1);
  return m;
}

render::Camera camera(uint32_t w, uint32_t h, const glm::dvec3& eye, const glm::dvec3& target) {
  render::Camera c;
  c.K.width = w;
  c.K.height = h;
  c.K.fx = c.K.fy = 0.9 * w;
  c.K.cx = 0.5 * w;
  c.K.cy = 0.5 * h;
  c.c2w = look_at(eye, target);
  return c;
}

struct Compare {
  size_t pixels = 0, within = 0;
};

// Pixels whose 4 channels are all within `tol` of 255 levels; the first mismatches printed.
Compare compare(const render::AppearanceImage& a, const render::AppearanceImage& b, int tol, const char* what) {
  Compare c;
  REQUIRE(a.rgba.size() == b.rgba.size());
  int printed = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) {
    bool ok = a.labels[i] == b.labels[i];
    for (int k = 0; k < 4; ++k)
      ok = ok && std::abs(static_cast<int>((a.rgba[i] >> (8 * k)) & 255u) - static_cast<int>((b.rgba[i] >> (8 * k)) & 255u)) <= tol;
    ++c.pixels;
    c.within += ok;
    if (!ok && printed < 5) {
      ++printed;
      std::printf("  %s: pixel (%zu, %zu): %08x label %08x vs %08x label %08x\n", what, i % a.width, i / a.width, a.rgba[i],
                  a.labels[i], b.rgba[i], b.labels[i]);
    }
  }
  return c;
}

double luminance(uint32_t p) {
  return 0.2126 * (p & 255u) + 0.7152 * ((p >> 8) & 255u) + 0.0722 * ((p >> 16) & 255u);
}

double mean_luminance(const render::AppearanceImage& img) {
  double s = 0;
  for (const uint32_t p : img.rgba) s += luminance(p);
  return s / static_cast<double>(img.rgba.size());
}

render::WorldLight headlight(const glm::dvec3& pos, const glm::dvec3& dir) {
  render::WorldLight l;
  l.pos = pos;
  l.dir = glm::normalize(dir);
  l.cos_cut = std::cos(0.6);
  l.range = 10.0;
  l.intensity = glm::vec3(3.0f);
  l.kind = APPEARANCE_LIGHT_HEADLIGHT;
  return l;
}

}  // namespace

TEST_CASE("appearance: GPU frames match the CPU reference under every look, at odd sizes") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = town(glm::dvec3(0.0));
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, g);
  render::AppearanceRendererGpu gpu_r(ctx);
  std::vector<render::WorldLight> lights = render::street_lamps(g);
  CHECK(lights.size() == 1);  // the 6.8 m pole
  lights.push_back(headlight({-2.0, -1.0, 0.9}, {1.0, 0.0, -0.05}));
  const struct {
    const char* prompt;
    uint32_t w, h;
    bool shadows, ao;
  } cases[] = {{"sunny noon", 97, 61, true, true},     {"night", 83, 47, true, true},
               {"thick fog", 64, 37, false, true},     {"rainy dusk", 101, 53, true, false},
               {"snowy morning", 77, 45, true, true},  {"overcast afternoon", 33, 17, false, false}};
  for (const auto& k : cases) {
    CAPTURE(k.prompt);
    const render::Camera cam = camera(k.w, k.h, {-8.0, 3.0, 1.7}, {12.0, 2.0, 0.5});
    const shader::AppearanceParams lp = render::lighting_params(render::parse_prompt(k.prompt), 7);
    render::AppearanceOptions o;
    o.shadows = k.shadows;
    o.ambient_occlusion = k.ao;
    const render::AppearanceImage a = gpu_r.render(rw, cam, lp, lights, o);
    const render::AppearanceImage b = render::render_appearance_cpu(g, cam, lp, lights, o, 2);
    const Compare c = compare(a, b, 2, k.prompt);
    INFO(c.within << " of " << c.pixels << " pixels within 2 levels");
    CHECK(c.within >= c.pixels * 995 / 1000);
    // Something of each kind is seen: sky and surfaces.
    size_t sky = 0;
    for (const uint8_t s : a.sky_mask8()) sky += s == 255;
    CHECK(sky > 0);
    CHECK(sky < a.rgba.size());
  }
}

TEST_CASE("appearance: frames are deterministic, the seed changes the procedural detail") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = town(glm::dvec3(0.0));
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, g);
  render::AppearanceRendererGpu r(ctx);
  const render::Camera cam = camera(120, 72, {-8.0, 3.0, 1.7}, {12.0, 8.0, 3.0});
  const auto l1 = render::lighting_params(render::parse_prompt("sunny"), 1);
  const auto l2 = render::lighting_params(render::parse_prompt("sunny"), 2);
  const render::AppearanceImage a = r.render(rw, cam, l1, {}, {});
  const render::AppearanceImage b = r.render(rw, cam, l1, {}, {});
  CHECK(a.rgba == b.rgba);
  CHECK(a.labels == b.labels);
  const render::AppearanceImage c = r.render(rw, cam, l2, {}, {});
  size_t differ = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) differ += a.rgba[i] != c.rgba[i];
  CHECK(differ > a.rgba.size() / 10);
  CHECK(a.labels == c.labels);
}

TEST_CASE("appearance: a town 100 km from the origin renders as at the origin") {
  gpu::Context& ctx = test::gpu_context();
  const glm::dvec3 far(100000.0, -100000.0, 50.0);
  const world::VoxelGrid g0 = town(glm::dvec3(0.0)), g1 = town(far);
  render::AppearanceRendererGpu r(ctx);
  const auto lp = render::lighting_params(render::parse_prompt("sunny noon"), 0);
  const glm::dvec3 eye(-8.0, 3.0, 1.7), target(12.0, 2.0, 0.5);
  const render::AppearanceImage a =
      r.render(render::upload_raycast_world(ctx, g0), camera(96, 64, eye, target), lp, render::street_lamps(g0), {});
  const render::AppearanceImage b = r.render(render::upload_raycast_world(ctx, g1),
                                             camera(96, 64, eye + far, target + far), lp, render::street_lamps(g1), {});
  const Compare c = compare(a, b, 2, "100 km");
  INFO(c.within << " of " << c.pixels);
  CHECK(c.within >= c.pixels * 99 / 100);
}

TEST_CASE("appearance: a ground point seen from two cameras keeps its colour (detail fixed to the world)") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = town(glm::dvec3(0.0));
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, g);
  render::AppearanceRendererGpu r(ctx);
  const auto lp = render::lighting_params(render::parse_prompt("overcast"), 0);
  const render::Camera ca = camera(800, 480, {-6.0, -6.0, 1.6}, {2.0, -7.0, 0.0});
  const render::Camera cb = camera(800, 480, {-3.0, -4.5, 2.2}, {3.0, -8.0, 0.0});
  const render::AppearanceImage ia = r.render(rw, ca, lp, {}, {}), ib = r.render(rw, cb, lp, {}, {});
  const std::vector<render::RayResult> ha = render::cast_camera_cpu(g, ca, {}, 2), hb = render::cast_camera_cpu(g, cb, {}, 2);
  const glm::dmat4 w2b = glm::inverse(cb.c2w);
  std::vector<double> same_point, same_pixel;
  for (size_t i = 0; i < ha.size(); ++i) {
    if (!ha[i].sem_hit || ha[i].class_id != kSidewalk) continue;
    const render::Ray ray = render::camera_ray(ca, static_cast<uint32_t>(i % ca.K.width), static_cast<uint32_t>(i / ca.K.width),
                                               render::PixelConvention::Integer);
    const glm::dvec3 p = ray.origin + ray.dir * ha[i].t_sem;
    const glm::dvec4 q = w2b * glm::dvec4(p, 1.0);
    if (q.z <= 0.1) continue;
    const long u = std::lround(cb.K.fx * q.x / q.z + cb.K.cx), v = std::lround(cb.K.fy * q.y / q.z + cb.K.cy);
    if (u < 0 || v < 0 || u >= static_cast<long>(cb.K.width) || v >= static_cast<long>(cb.K.height)) continue;
    const size_t j = static_cast<size_t>(v) * cb.K.width + static_cast<size_t>(u);
    if (!hb[j].sem_hit) continue;
    const render::Ray rb = render::camera_ray(cb, static_cast<uint32_t>(u), static_cast<uint32_t>(v), render::PixelConvention::Integer);
    if (glm::length(rb.origin + rb.dir * hb[j].t_sem - p) > 0.001) continue;  // the same point within 1 mm
    same_point.push_back(std::abs(luminance(ia.rgba[i]) - luminance(ib.rgba[j])));
    same_pixel.push_back(std::abs(luminance(ia.rgba[i]) - luminance(ib.rgba[i])));
  }
  REQUIRE(same_point.size() >= 20);
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return s / static_cast<double>(v.size());
  };
  INFO(same_point.size() << " matched points: mean |dL| " << mean(same_point) << " at the same point, "
                         << mean(same_pixel) << " at the same pixel");
  CHECK(mean(same_point) <= 2.5);
  CHECK(mean(same_pixel) > 2.0 * mean(same_point));
}

TEST_CASE("appearance: shadows and ambient occlusion darken, night is darker than day, fog lowers far contrast") {
  gpu::Context& ctx = test::gpu_context();
  const scene::Scene s = world::make_demo_scene();
  const world::ProceduralPrior prior(s);
  const test::FirstChunks gen(prior, 2);
  world::WorldBuildOptions bo;
  bo.threads = 2;
  const world::VoxelGrid w = world::build_world(s, gen, bo).world;
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, w);
  render::AppearanceRendererGpu r(ctx);
  const render::Camera cam = render::camera_from_scene(scene::rescale_camera(s.cameras[0], 208, 120), s.ego[20].ego_to_world);
  auto frame = [&](const char* prompt, bool shadows, bool ao) {
    render::AppearanceOptions o;
    o.shadows = shadows;
    o.ambient_occlusion = ao;
    const render::AppearancePrompt p = render::parse_prompt(prompt);
    return r.render(rw, cam, render::lighting_params(p, 0), render::lamps_on(p) ? render::street_lamps(w) : std::vector<render::WorldLight>{}, o);
  };
  const render::AppearanceImage day = frame("sunny noon", true, true);
  const double l_day = mean_luminance(day);
  CHECK(mean_luminance(frame("sunny noon", false, true)) > l_day);
  CHECK(mean_luminance(frame("sunny noon", true, false)) > l_day);
  const double l_night = mean_luminance(frame("night", true, true));
  INFO("mean luminance: day " << l_day << ", night " << l_night);
  CHECK(l_night < 0.5 * l_day);
  // Contrast (standard deviation of luminance) of the surfaces beyond 40 m.
  const std::vector<render::RayResult> hits = render::cast_camera_cpu(w, cam, {});
  auto far_contrast = [&](const render::AppearanceImage& img) {
    std::vector<double> l;
    for (size_t i = 0; i < hits.size(); ++i)
      if (hits[i].sem_hit && hits[i].t_sem > 40.0) l.push_back(luminance(img.rgba[i]));
    REQUIRE(l.size() >= 50);
    double m = 0, v = 0;
    for (double x : l) m += x;
    m /= static_cast<double>(l.size());
    for (double x : l) v += (x - m) * (x - m);
    return std::sqrt(v / static_cast<double>(l.size()));
  };
  const double c_clear = far_contrast(day), c_fog = far_contrast(frame("foggy noon", true, true));
  INFO("far contrast: clear " << c_clear << ", fog " << c_fog);
  CHECK(c_fog < 0.5 * c_clear);
}

TEST_CASE("appearance/shadow_rays: the building's shadow on the ground, where the CPU's sun ray is blocked") {
  gpu::Context& ctx = test::gpu_context();
  const world::VoxelGrid g = town(glm::dvec3(0.0));
  const render::RaycastWorld rw = render::upload_raycast_world(ctx, g);
  render::AppearanceRendererGpu r(ctx);
  const auto lp = render::lighting_params(render::parse_prompt("sunny afternoon"), 0);
  const render::Camera cam = camera(91, 57, {-4.0, -2.0, 6.0}, {12.0, 6.0, 0.0});
  render::AppearanceOptions lit_o, dark_o;
  lit_o.shadows = false;
  lit_o.ambient_occlusion = dark_o.ambient_occlusion = false;
  const render::AppearanceImage with = r.render(rw, cam, lp, {}, dark_o), without = r.render(rw, cam, lp, {}, lit_o);
  // The CPU decides each ground pixel's sun visibility from the same origin rule as shadow_rays.comp.
  const std::vector<render::RayResult> hits = render::cast_camera_cpu(g, cam, {});
  const glm::dvec3 sun(lp.sun_x, lp.sun_y, lp.sun_z);
  size_t shadowed = 0, agree = 0, ground = 0;
  for (size_t i = 0; i < hits.size(); ++i) {
    if (!hits[i].sem_hit || hits[i].normal != 3) continue;  // up-facing faces
    ++ground;
    const render::Ray ray = render::camera_ray(cam, static_cast<uint32_t>(i % cam.K.width),
                                               static_cast<uint32_t>(i / cam.K.width), render::PixelConvention::Integer);
    render::Ray sr;
    sr.origin = ray.origin + ray.dir * hits[i].t_sem + glm::dvec3(0.0, 0.0, 0.02 * g.voxel_size());
    sr.dir = sun;
    render::RaycastOptions so;
    so.t_max = 150.0;
    const bool blocked = render::cast_ray_cpu(g, render::raycast_bounds(g), sr, so).sem_hit;
    shadowed += blocked;
    const bool darker = luminance(with.rgba[i]) < luminance(without.rgba[i]) - 1.0;
    agree += darker == blocked;
  }
  INFO(ground << " ground pixels, " << shadowed << " in the CPU's shadow, " << agree << " agree");
  REQUIRE(ground > 500);
  CHECK(shadowed > 50);
  CHECK(agree >= ground * 99 / 100);
}
