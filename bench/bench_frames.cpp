// icube-bench-frames: the procedural appearance renderer (Stage 2's built-in
// frames, engine/render/appearance/) — frames per second at 832 x 480 on the
// demo town with and without shadow rays and ambient occlusion, at noon and
// at night (street lamps + headlights), next to the camera cast alone (what
// every variant pays first). Whole frames: record, submit, wait, download of
// the RGBA and label buffers; the static world resident, cars of the frame
// patched in once. Same run: the GPU frame against the CPU reference
// (render_appearance_cpu: double ray caster, VoxelGrid probes, the same
// shading model) on a 208 x 120 camera of the same view: share of pixels
// within 2 of 255 per channel.
//
//   LP_NUM_THREADS=2 build/icube-bench-frames [--runs 7] [--warmup 2] [--frame K] [--waymo]
#include "bench_host.h"
#include "bench_stats.h"
#include "bench_worlds.h"

#include "gpu/context.h"
#include "render/appearance/appearance_cpu.h"
#include "render/appearance/appearance_gpu.h"
#include "render/appearance/frames_render.h"
#include "render/appearance/lighting.h"
#include "render/buffers/dynamic_cars.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"
#include "render/buffers/trajectory.h"
#include "scene/frames.h"
#include "scene/scene_load.h"
#include "world/car_mesh.h"
#include "world/demo_scene.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

using namespace icube;

namespace {

using Clock = std::chrono::steady_clock;

struct Variant {
  std::string name;
  std::string prompt;
  bool shadows, ao;
};

double agreement(const render::AppearanceImage& a, const render::AppearanceImage& b) {
  size_t ok = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) {
    bool same = true;
    for (int c = 0; c < 4; ++c) {
      const int x = static_cast<int>((a.rgba[i] >> (8 * c)) & 255u), y = static_cast<int>((b.rgba[i] >> (8 * c)) & 255u);
      same = same && std::abs(x - y) <= 2;
    }
    ok += same;
  }
  return a.rgba.empty() ? 1.0 : static_cast<double>(ok) / static_cast<double>(a.rgba.size());
}

bool run_world(gpu::Context& ctx, const std::string& label, const world::VoxelGrid& world, const scene::Scene& sc,
               int frame, int runs, int warmup) {
  const world::TriangleMesh mesh = world::builtin_car_mesh();
  const scene::Camera preset = render::camera_preset("waymo-front-480p");
  const render::Trajectory tr = render::ego_trajectory(sc, preset);
  const size_t f = frame < 0 ? tr.size() / 2 : std::min(tr.size() - 1, static_cast<size_t>(frame));
  const int ti = tr.time_index[f];
  const world::VoxelGrid stat = render::make_static_world(world, sc, std::max(0, ti), mesh);
  render::OverlayWorld overlay(ctx, stat);
  render::DynamicCarOverlay cars(overlay, &sc, mesh);
  render::DynamicCarCosts costs;
  cars.set_time(ti, costs);
  render::Camera cam;
  cam.K = render::intrinsics_of(preset);
  cam.c2w = tr.c2w[f];
  const std::vector<render::WorldLight> lamps = render::street_lamps(stat);
  std::printf("\n%s: frame %zu, %ux%u, %zu bricks, %zu street lamps\n", label.c_str(), f, cam.K.width, cam.K.height,
              stat.brick_count(), lamps.size());
  std::printf("%-44s %10s %10s %8s %10s\n", "variant", "min ms", "median ms", "fps", "vs CPU ref");

  render::AppearanceRendererGpu renderer(ctx);
  render::RaycasterGpu caster(ctx);
  caster.set_exact(false);
  gpu::Buffer hits(ctx, size_t{cam.K.width} * cam.K.height * sizeof(shader::RaycastHit));
  {  // The camera cast alone.
    std::vector<double> ms;
    for (int i = 0; i < warmup + runs; ++i) {
      const auto t0 = Clock::now();
      ctx.submit_and_wait([&](gpu::CommandList& cmd) { caster.record_camera(cmd, overlay.world(), cam, {}, hits); });
      if (i >= warmup) ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    const bench::Summary s = bench::summarize(ms);
    std::printf("%-44s %10.1f %10.1f %8.2f %10s\n", "camera cast alone (no readback)", s.min_ms, s.median_ms,
                1000.0 / s.median_ms, "-");
  }
  const std::vector<Variant> variants = {
      {"noon: no shadows, no AO", "sunny noon", false, false},
      {"noon: shadows", "sunny noon", true, false},
      {"noon: AO", "sunny noon", false, true},
      {"noon: shadows + AO (default)", "sunny noon", true, true},
      {"night: lamps + headlights, AO", "night", true, true},
  };
  render::Camera small = cam;
  small.K = render::intrinsics_of(scene::rescale_camera(preset, 208, 120));
  bool ok = true;
  for (const Variant& v : variants) {
    const render::AppearancePrompt p = render::parse_prompt(v.prompt);
    const shader::AppearanceParams lighting = render::lighting_params(p, 0);
    const std::vector<render::WorldLight> lights = render::frame_lights(p, lamps, &sc, ti);
    render::AppearanceOptions o;
    o.shadows = v.shadows;
    o.ambient_occlusion = v.ao;
    std::vector<double> ms;
    for (int i = 0; i < warmup + runs; ++i) {
      const auto t0 = Clock::now();
      const render::AppearanceImage img = renderer.render(overlay.world(), cam, lighting, lights, o);
      if (i >= warmup) ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    const bench::Summary s = bench::summarize(ms);
    // Correctness on a small camera of the same view (the static world: the CPU reference has no overlay).
    render::OverlayWorld plain(ctx, stat);
    const render::AppearanceImage g = renderer.render(plain.world(), small, lighting, lights, o);
    const render::AppearanceImage c = render::render_appearance_cpu(stat, small, lighting, lights, o, 2);
    const double agree = agreement(g, c);
    ok = ok && agree >= 0.99;
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.2f %%%s", 100.0 * agree, agree >= 0.99 ? "" : " FAIL");
    std::printf("%-44s %10.1f %10.1f %8.2f %10s\n", v.name.c_str(), s.min_ms, s.median_ms, 1000.0 / s.median_ms, buf);
  }
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"icube-bench-frames: procedural appearance frames per second, shadows and AO on and off"};
  int runs = 7, warmup = 2, frame = -1;
  bool waymo = false;
  app.add_option("--runs", runs, "Timed runs per variant")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--warmup", warmup, "Untimed runs first")->capture_default_str();
  app.add_option("--frame", frame, "Ego frame (default: the middle one)");
  app.add_flag("--waymo", waymo, "Also the Waymo scenario's world ($ICUBE_TEST_DATA)");
  CLI11_PARSE(app, argc, argv);
  try {
    gpu::Context ctx(gpu::ContextOptions::from_env());
    std::printf("device: %s; LP_NUM_THREADS=%s\n", ctx.info().name.c_str(), bench::env_or_unset("LP_NUM_THREADS").c_str());
    bool ok = true;
    {
      const scene::Scene sc = world::make_demo_scene();
      double s = 0.0;
      const world::VoxelGrid w = bench::build_procedural(sc, world::PlanMode::Trajectory, s);
      ok = run_world(ctx, "demo town (procedural, trajectory mode)", w, sc, frame, runs, warmup) && ok;
    }
    if (waymo) {
      const char* env = std::getenv("ICUBE_TEST_DATA");
      const std::string path = std::string(env ? env : "../shared/data") + "/maps/waymo/motion_data_one_scenario.tfrecord";
      if (!std::filesystem::exists(path)) {
        std::printf("\nskip waymo: %s not found (set ICUBE_TEST_DATA)\n", path.c_str());
      } else {
        scene::Scene sc = scene::load_scene(path);
        if (scene::tracks_unclassified(sc)) scene::classify_tracks(sc);
        double s = 0.0;
        const world::VoxelGrid w = bench::build_procedural(sc, world::PlanMode::Blocks, s);
        ok = run_world(ctx, "waymo scenario (procedural, blocks mode)", w, sc, frame, runs, warmup) && ok;
      }
    }
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-bench-frames: %s\n", e.what());
    return 1;
  }
}
