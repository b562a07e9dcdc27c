// icube-bench-raycast: the GPU voxel ray caster (shaders/raycast/cast.comp: 32³
// super-brick and 8³ brick skipping via occupancy masks, then an exact voxel
// DDA) against the CPU reference (engine/render/raycast_cpu.h, brute-force
// double DDA on --cpu-threads std::threads) and, when the build found it,
// OpenVDB's VolumeRayIntersector (leaf-level HDDA + math::DDA to the first
// active voxel, --cpu-threads std::threads, one intersector copy per thread) in
// one run, on the same voxels and rays, with correctness checks against the CPU.
//
// Cases:
//  - "synthetic chunk": an InfiniCube-like fine chunk at 0.2 m, 256 x 256 x 128
//    voxels: a one-voxel ground slab, a road corridor along x with parked
//    "cars" (solid 22 x 10 x 8 boxes) and hollow "buildings" (box shells), fixed
//    seed; the camera 2 m above the road at the chunk's -x end looking +x.
//  - "demo (trajectory)": the embedded demo scene built by world::build_world
//    with the procedural prior (trajectory mode); camera on the ego track.
//  - "waymo (blocks)": $ICUBE_TEST_DATA/maps/waymo/motion_data_one_scenario.tfrecord
//    (default ../shared/data; skipped with a message when absent), blocks mode;
//    camera on the ego track.
// Cameras: the Waymo FRONT preset at 832 x 480 (scene/frames.h), InfiniCube's
// integer pixels; on the ego track at --frame (default: the middle frame).
// Rows: GPU kernel time (timestamps) and submit wall time for the default
// kernel (occupancy masks built at the first record of the world and kept, 2-D
// pixel tiles per workgroup), the same with the masks rebuilt every record (the
// world's revision bumped), with row-major workgroups, the previous kernel's path
// (hash lookups, rows), the float-only exact pass (double-float chords, the
// route of devices without shaderFloat64) and the float pass alone next to the
// default's double chords, the flat GPU walk (--flat, no skipping), the CPU
// reference, OpenVDB. min / median of --runs after --warmup; lane utilisation
// (mean steps / mean of each subgroup's longest ray);
// Mrays/s from the median; steps/ray from the results (GPU: voxel steps +
// skipped cells; CPU: voxels; OpenVDB: leaf intervals + voxel DDA steps).
// OpenVDB's hit is the first active voxel (no 1 cm chord threshold), so its
// check compares the first-hit distance with the CPU's semantic hit.
//
//   LP_NUM_THREADS=2 icube-bench-raycast --cpu-threads 2 [--runs 7] [--warmup 2] [--case all|synthetic|demo|waymo] [--quick]
#include "bench_host.h"
#include "gpu/commands.h"
#include "render/raycast_cpu.h"
#include "render/raycast_gpu.h"
#include "render/buffers/trajectory.h"
#include "scene/frames.h"
#include "scene/scene_load.h"
#include "world/demo_scene.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"
#include "bench_worlds.h"

#ifdef ICUBE_BENCH_OPENVDB
#include <openvdb/math/DDA.h>
#include <openvdb/math/Ray.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/RayIntersector.h>
#endif

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <thread>
#include <string>
#include <vector>

using namespace icube;
using Clock = std::chrono::steady_clock;

namespace {

world::VoxelGrid make_world(uint32_t seed) {
  world::VoxelGrid g(glm::dvec3(0.0), 0.2);
  std::mt19937 rng(seed);
  for (int i = -128; i < 128; ++i)
    for (int j = -128; j < 128; ++j) g.set({i, j, 0}, 17 /* road / ground */, 0);
  auto box = [&](glm::ivec3 lo, glm::ivec3 size, uint8_t cls, uint16_t inst, bool hollow) {
    for (int i = 0; i < size.x; ++i)
      for (int j = 0; j < size.y; ++j)
        for (int k = 0; k < size.z; ++k) {
          const bool shell = i == 0 || j == 0 || k == 0 || i == size.x - 1 || j == size.y - 1 || k == size.z - 1;
          if (!hollow || shell) {
            const glm::ivec3 p = lo + glm::ivec3(i, j, k);
            if (p.x >= -128 && p.x < 128 && p.y >= -128 && p.y < 128 && p.z < 128) g.set(p, cls, inst);
          }
        }
  };
  uint16_t inst = 1;
  std::uniform_int_distribution<int> gapd(2, 12), wd(12, 40), hd(20, 110);
  for (int side : {-1, 1}) {
    for (int x = -128; x < 128;) {  // buildings beside the road (|y| > 30 voxels = 6 m)
      const int w = wd(rng), depth = wd(rng), h = hd(rng);
      const int y0 = side > 0 ? 32 + gapd(rng) : -32 - gapd(rng) - depth;
      box({x, y0, 1}, {w, depth, h}, 15 /* building */, inst++, true);
      x += w + gapd(rng);
    }
    for (int x = -100; x < 128; x += 30 + gapd(rng) * 3)  // parked cars in the parking strips
      box({x, side > 0 ? 16 : -26, 1}, {22, 10, 8}, 1 /* car */, static_cast<uint16_t>(10000 + inst++), false);
  }
  return g;
}

render::Camera make_camera(uint32_t width, uint32_t height) {
  const scene::Camera preset = scene::rescale_camera(scene::waymo_front_camera(), width, height);
  render::Camera c;
  c.K = {preset.fx, preset.fy, preset.cx, preset.cy, width, height};
  // OpenCV axes in the world (z up): right = -y, down = -z, forward = +x.
  c.c2w = glm::dmat4(glm::dvec4(0, -1, 0, 0), glm::dvec4(0, 0, -1, 0), glm::dvec4(1, 0, 0, 0),
                     glm::dvec4(-24.0, 0.03, 2.0 + 0.2, 1.0));
  return c;
}

struct Stat {
  double min_ms = 0.0, median_ms = 0.0;
};

Stat summarize(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  if (v.empty()) return {NAN, NAN};
  const size_t n = v.size();
  return {v[0], n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2])};
}

struct Row {
  std::string name;
  Stat s;
  double steps_per_ray = NAN;
  std::string check;
};

struct Case {
  std::string name;
  world::VoxelGrid grid;
  render::Camera cam;
};

// The Waymo FRONT 832x480 camera at the ego track's frame `frame` (-1: the middle).
render::Camera ego_camera(const scene::Scene& sc, int frame) {
  const scene::Camera preset = render::camera_preset("waymo-front-480p");
  const render::Trajectory tr = render::ego_trajectory(sc, preset);
  if (tr.size() == 0) throw std::runtime_error("scene has no valid ego pose");
  const size_t i = frame < 0 ? tr.size() / 2 : std::min(tr.size() - 1, static_cast<size_t>(frame));
  render::Camera c;
  c.K = render::intrinsics_of(preset);
  c.c2w = tr.c2w[i];
  return c;
}


#ifdef ICUBE_BENCH_OPENVDB
struct VdbResult {
  bool hit = false;
  double t = 0.0;
  openvdb::Coord ijk;
  uint32_t steps = 0;
};

// First active voxel along each ray: VolumeRayIntersector at leaf level (8³
// intervals), then a voxel DDA inside each interval. Index space = our ijk
// (voxel i covers [i, i + 1)); direction d / vs, so t is in metres.
std::vector<VdbResult> cast_openvdb(const openvdb::Int32Grid& grid, const glm::dvec3& origin, double vs,
                                    const std::vector<render::Ray>& rays, unsigned threads) {
  using RayT = openvdb::math::Ray<double>;
  using Inter = openvdb::tools::VolumeRayIntersector<openvdb::Int32Grid, 0, RayT>;
  const Inter master(grid);
  std::vector<VdbResult> out(rays.size());
  constexpr size_t kChunk = 64;
  auto work = [&](unsigned tid) {
    Inter inter(master);  // shallow copy: one per thread
    openvdb::Int32Grid::ConstAccessor acc = grid.getConstAccessor();
    for (size_t c = size_t{tid} * kChunk; c < rays.size(); c += size_t{threads} * kChunk)
      for (size_t i = c; i < std::min(rays.size(), c + kChunk); ++i) {
        const glm::dvec3 e = (rays[i].origin - origin) / vs, d = rays[i].dir / vs;
        const RayT ray(openvdb::Vec3d(e.x, e.y, e.z), openvdb::Vec3d(d.x, d.y, d.z), 0.0);
        VdbResult& r = out[i];
        if (!inter.setIndexRay(ray)) continue;
        double t0 = 0.0, t1 = 0.0;
        while (!r.hit && inter.march(t0, t1)) {
          ++r.steps;
          openvdb::math::DDA<RayT, 0> dda(ray, t0, t1);
          do {
            ++r.steps;
            if (acc.isValueOn(dda.voxel())) {
              r.hit = true;
              r.t = dda.time();
              r.ijk = dda.voxel();
              break;
            }
          } while (dda.step());
        }
      }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (std::thread& th : pool) th.join();
  return out;
}
#endif

bool run_case(gpu::Context& ctx, const Case& c, const render::RaycastOptions& opts, int runs, int warmup,
              unsigned cpu_threads, bool flat, bool quick) {
  const world::VoxelGrid& grid = c.grid;
  const render::Camera& cam = c.cam;
  const uint64_t n = uint64_t{cam.K.width} * cam.K.height;
  const world::IjkBounds wb = render::raycast_bounds(grid);
  std::printf("\n== %s: %llu voxels in %zu bricks (0.2 m), brick bounds %dx%dx%d voxels; camera %ux%u at "
              "(%.1f, %.1f, %.1f), %llu rays\n",
              c.name.c_str(), static_cast<unsigned long long>(grid.voxel_count()), grid.brick_count(),
              wb.empty() ? 0 : wb.max.x - wb.min.x + 1, wb.empty() ? 0 : wb.max.y - wb.min.y + 1,
              wb.empty() ? 0 : wb.max.z - wb.min.z + 1, cam.K.width, cam.K.height, cam.c2w[3].x, cam.c2w[3].y,
              cam.c2w[3].z, static_cast<unsigned long long>(n));

  render::RaycastWorld w = render::upload_raycast_world(ctx, grid);
  gpu::Buffer hits(ctx, n * sizeof(shader::RaycastHit), gpu::MemoryUsage::DeviceLocal, "bench-raycast-hits");
  std::vector<Row> rows;

  // CPU reference first: its results are the correctness baseline.
  std::vector<render::RayResult> cpu;
  {
    std::vector<double> ms;
    const int cpu_runs = quick ? 1 : std::max(5, runs / 2);
    for (int i = 0; i < 1 + cpu_runs; ++i) {
      const Clock::time_point t0 = Clock::now();
      cpu = render::cast_camera_cpu(grid, cam, opts, cpu_threads);
      const double t = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      if (i >= 1) ms.push_back(t);
      std::fprintf(stderr, "cpu run %d: %.1f ms\n", i, t);
    }
    double steps = 0.0;
    size_t hit_count = 0;
    for (const auto& r : cpu) {
      steps += r.steps;
      hit_count += r.sem_hit;
    }
    rows.push_back({"cpu reference DDA, " + std::to_string(cpu_threads) + " thread(s)", summarize(ms), steps / n, "ref"});
    std::printf("cpu: %zu of %llu rays have a semantic hit\n", hit_count, static_cast<unsigned long long>(n));
  }

  // exact: the exact pass as on this device (Exact::Auto: double chords where it has shaderFloat64),
  // forced to the double-float pass of devices without it (Exact::FloatOnly), or off.
  enum class Exact { Auto, FloatOnly, Off };
  auto gpu_rows = [&](bool skip, bool occupancy, bool tiled, bool rebuild, const std::string& label,
                      Exact exact = Exact::Auto) {
    render::RaycasterGpu rc(ctx, skip);
    rc.set_occupancy(occupancy);
    rc.set_tiled(tiled);
    rc.set_exact(exact != Exact::Off);
    rc.set_exact_float_only(exact == Exact::FloatOnly);
    gpu::GpuTimer timer(ctx, 1);
    std::vector<double> kernel_ms, submit_ms, cpu_ms;
    for (int i = 0; i < warmup + runs; ++i) {
      int iv = 0;
      if (rebuild) ++w.revision;  // as if the world changed: the record rebuilds the occupancy masks
      const bench::CpuTimes c0 = bench::cpu_times_now();
      const Clock::time_point t0 = Clock::now();
      ctx.submit_and_wait([&](gpu::CommandList& cmd) {
        timer.reset(cmd);
        cmd.barrier(gpu::deps::kComputeToCompute);  // the previous run wrote the same hits
        iv = timer.begin(cmd, "raycast");
        rc.record_camera(cmd, w, cam, opts, hits);
        timer.end(cmd, iv);
      });
      const double wall = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      const bench::CpuTimes c1 = bench::cpu_times_now();
      if (i >= warmup) {
        kernel_ms.push_back(timer.milliseconds(iv));
        submit_ms.push_back(wall);
        cpu_ms.push_back(1e3 * (c1.own_s - c0.own_s));
      }
      std::fprintf(stderr, "%s run %d: %.1f ms\n", label.c_str(), i, wall);
    }
    const auto h = gpu::download_vector<shader::RaycastHit>(ctx, hits, n);
    size_t bad = 0, normal_only = 0;
    double steps = 0.0, max_dt = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const render::RayResult& r = cpu[i];
      const bool sem = (h[i].flags & RAYCAST_FLAG_SEM) != 0, dep = (h[i].flags & RAYCAST_FLAG_DEPTH) != 0;
      bool ok = sem == r.sem_hit && dep == r.depth_hit;
      if (ok && sem)
        ok = glm::ivec3(h[i].ijk_x, h[i].ijk_y, h[i].ijk_z) == r.ijk && h[i].sem_class == r.class_id &&
             std::fabs(static_cast<double>(h[i].t_sem) - r.t_sem) <= 2e-4;
      if (ok && dep) ok = std::fabs(static_cast<double>(h[i].t_depth) - r.t_depth) <= 2e-4;
      if (ok && sem) {
        max_dt = std::max(max_dt, std::fabs(static_cast<double>(h[i].t_sem) - r.t_sem));
        normal_only += h[i].normal != r.normal;
      }
      if (!ok && bad < 10)
        std::printf("  %s: ray %zu differs: gpu flags %u voxel (%d, %d, %d) class %u t_sem %.6f t_depth %.6f; cpu "
                    "sem %d depth %d voxel (%d, %d, %d) class %u t_sem %.6f t_depth %.6f\n",
                    label.c_str(), i, h[i].flags, h[i].ijk_x, h[i].ijk_y, h[i].ijk_z, h[i].sem_class,
                    static_cast<double>(h[i].t_sem), static_cast<double>(h[i].t_depth), int(r.sem_hit),
                    int(r.depth_hit), r.ijk.x, r.ijk.y, r.ijk.z, unsigned(r.class_id), r.t_sem, r.t_depth);
      bad += !ok;
      steps += h[i].steps;
    }
    {  // SIMD occupancy of the steps: lanes of one workgroup run as long as their longest ray
      const uint32_t W = cam.K.width, H = cam.K.height, tw = tiled ? rc.tile_width() : ctx.subgroup_size();
      const uint32_t th = tiled ? ctx.subgroup_size() / tw : 1;
      double tile_max = 0.0;
      for (uint32_t ty = 0; ty < H; ty += th)
        for (uint32_t tx = 0; tx < W; tx += tw) {
          uint32_t m = 0;
          for (uint32_t y = ty; y < std::min(H, ty + th); ++y)
            for (uint32_t x = tx; x < std::min(W, tx + tw); ++x) m = std::max(m, h[size_t{y} * W + x].steps);
          tile_max += double(m) * tw * th;
        }
      double total = 0.0;
      for (size_t i = 0; i < n; ++i) total += h[i].steps;
      std::printf("%s: lane utilisation %.2f (mean steps / mean of the workgroup's longest ray)\n", label.c_str(),
                  total / tile_max);
    }
    const bool pass = static_cast<double>(bad) <= 1e-5 * static_cast<double>(n);
    std::printf("%s: %zu of %llu rays differ from the CPU (flags, voxel, class, |dt| <= 2e-4 m), %zu other "
                "entry face, max |dt| %.2g m: %s\n",
                label.c_str(), bad, static_cast<unsigned long long>(n), normal_only, max_dt, pass ? "ok" : "FAIL");
    rows.push_back({label + ": kernel", summarize(kernel_ms), steps / n, pass ? "ok" : "FAIL"});
    rows.push_back({label + ": submit", summarize(submit_ms), steps / n, pass ? "ok" : "FAIL"});
    // This process's CPU time per run (lavapipe's threads + the submitting thread): on a shared
    // machine other processes inflate it far less than wall time. Not a rate: its Mrays/s column
    // is rays per CPU-second.
    rows.push_back({label + ": cpu time", summarize(cpu_ms), steps / n, pass ? "ok" : "FAIL"});
    return pass;
  };
  bool ok = gpu_rows(true, true, true, false, "gpu occupancy, tiles (default)");
  if (!quick) {
    ok = gpu_rows(true, true, true, true, "gpu occupancy rebuilt per record, tiles") && ok;
    ok = gpu_rows(true, true, false, false, "gpu occupancy, rows") && ok;
    if (!render::RaycasterGpu(ctx).exact_float_only())  // the route of devices without shaderFloat64
      ok = gpu_rows(true, true, true, false, "gpu float-only exact (df chords), tiles", Exact::FloatOnly) && ok;
    // The float pass alone (no device's route; its 1e-5 check is informative only).
    gpu_rows(true, true, true, false, "gpu float pass alone (no exact), tiles", Exact::Off);
    ok = gpu_rows(true, false, false, false, "gpu hash skip, rows (old path)") && ok;
  }
  if (flat) ok = gpu_rows(false, false, false, false, "gpu flat walk (no skip)") && ok;

#ifdef ICUBE_BENCH_OPENVDB
  {
    openvdb::initialize();
    openvdb::Int32Grid::Ptr vg = openvdb::Int32Grid::create(0);
    {
      openvdb::Int32Grid::Accessor acc = vg->getAccessor();
      grid.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
        acc.setValue(openvdb::Coord(ijk.x, ijk.y, ijk.z), static_cast<int32_t>(v.class_id));
      });
    }
    const std::vector<render::Ray> rays = render::camera_rays(cam, opts.pixels);  // outside the timing
    std::vector<double> ms, cpu_ms;
    std::vector<VdbResult> vr;
    for (int i = 0; i < 1 + (quick ? 3 : std::max(5, runs / 2)); ++i) {
      const bench::CpuTimes c0 = bench::cpu_times_now();
      const Clock::time_point t0 = Clock::now();
      vr = cast_openvdb(*vg, grid.origin(), grid.voxel_size(), rays, cpu_threads);
      const double t = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      const bench::CpuTimes c1 = bench::cpu_times_now();
      if (i >= 1) {
        ms.push_back(t);
        cpu_ms.push_back(1e3 * (c1.own_s - c0.own_s));
      }
      std::fprintf(stderr, "openvdb run %d: %.1f ms\n", i, t);
    }
    size_t flag_diff = 0, same_voxel = 0, both = 0, t_close = 0;
    double steps = 0.0;
    for (size_t i = 0; i < n; ++i) {
      steps += vr[i].steps;
      if (vr[i].hit != cpu[i].sem_hit) {
        ++flag_diff;
        continue;
      }
      if (!vr[i].hit) continue;
      ++both;
      same_voxel += vr[i].ijk == openvdb::Coord(cpu[i].ijk.x, cpu[i].ijk.y, cpu[i].ijk.z);
      t_close += std::fabs(vr[i].t - cpu[i].t_sem) <= 1e-3;
    }
    std::printf("openvdb: %zu of %llu rays differ in the hit flag from the CPU's semantic hit; of %zu rays both hit, "
                "%zu the same voxel, %zu first-hit distance within 1 mm (first active voxel vs >= 1 cm chord)\n",
                flag_diff, static_cast<unsigned long long>(n), both, same_voxel, t_close);
    const double agree = static_cast<double>(n - flag_diff - (both - t_close)) / static_cast<double>(n);
    char chk[32];
    std::snprintf(chk, sizeof chk, "%.4f%%", 100.0 * agree);
    rows.push_back({"openvdb VolumeRayIntersector, " + std::to_string(cpu_threads) + " thr", summarize(ms), steps / n,
                    chk});
    rows.push_back({"openvdb VolumeRayIntersector: cpu time", summarize(cpu_ms), steps / n, chk});
  }
#else
  std::printf("openvdb: not found at configure time (install libopenvdb-dev and re-run cmake), row skipped\n");
#endif

  std::printf("\n%-44s %10s %10s %10s %10s %8s\n", c.name.c_str(), "min ms", "median ms", "Mrays/s", "steps/ray",
              "check");
  for (const Row& r : rows)
    std::printf("%-44s %10.2f %10.2f %10.2f %10.1f %8s\n", r.name.c_str(), r.s.min_ms, r.s.median_ms,
                static_cast<double>(n) / (r.s.median_ms * 1e3), r.steps_per_ray, r.check.c_str());
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"GPU voxel ray caster vs the CPU reference DDA and OpenVDB (Mrays/s)", "icube-bench-raycast"};
  int runs = 7, warmup = 2, frame = -1;
  unsigned cpu_threads = 1;
  uint32_t width = scene::kInfiniCubeWidth, height = scene::kInfiniCubeHeight;
  uint32_t seed = 1;
  bool flat = false, quick = false;
  std::string which = "all", data;
  app.add_option("--runs", runs, "timed runs (>= 5)")->check(CLI::Range(5, 1000));
  app.add_option("--warmup", warmup, "untimed runs first")->check(CLI::Range(0, 100));
  app.add_option("--cpu-threads", cpu_threads, "std::threads for the CPU reference and OpenVDB")
      ->check(CLI::Range(1u, 256u));
  app.add_option("--width", width, "synthetic case: image width")->check(CLI::Range(1u, 16384u));
  app.add_option("--height", height, "synthetic case: image height")->check(CLI::Range(1u, 16384u));
  app.add_option("--seed", seed, "synthetic world seed");
  app.add_option("--frame", frame, "ego-track frame of the demo and Waymo cameras (default: the middle one)");
  app.add_option("--case", which, "all, synthetic, demo or waymo")
      ->check(CLI::IsMember({"all", "synthetic", "demo", "waymo"}));
  app.add_option("--data", data, "test data directory (default $ICUBE_TEST_DATA or ../shared/data)");
  app.add_flag("--flat", flat, "add the flat GPU walk rows (slow)");
  app.add_flag("--quick", quick, "one CPU reference run, three OpenVDB runs, only the default GPU row (for tuning)");
  CLI11_PARSE(app, argc, argv);
  if (data.empty()) {
    const char* env = std::getenv("ICUBE_TEST_DATA");
    data = env && *env ? env : "../shared/data";
  }
  const render::RaycastOptions opts;

  gpu::Context ctx(gpu::ContextOptions::from_env());
  const gpu::DeviceInfo& d = ctx.info();
  std::printf("device: %s (%s %s), subgroup %u\n", d.name.c_str(), d.driver_name.c_str(), d.driver_info.c_str(),
              d.subgroup_size);
  std::printf("cpu: %s, %u online; LP_NUM_THREADS=%s LP_NATIVE_VECTOR_WIDTH=%s; --cpu-threads %u\n",
              bench::cpu_model().c_str(), bench::online_cpus(), bench::env_or_unset("LP_NUM_THREADS").c_str(),
              bench::env_or_unset("LP_NATIVE_VECTOR_WIDTH").c_str(), cpu_threads);

  bool ok = true;
  if (which == "all" || which == "synthetic")
    ok = run_case(ctx, {"synthetic chunk", make_world(seed), make_camera(width, height)}, opts, runs, warmup,
                  cpu_threads, flat, quick) && ok;
  if (which == "all" || which == "demo") {
    const scene::Scene sc = world::make_demo_scene();
    double s = 0.0;
    Case c{"demo (trajectory)", bench::build_procedural(sc, world::PlanMode::Trajectory, s), ego_camera(sc, frame)};
    std::printf("\n(demo world built in %.1f s, not timed below)\n", s);
    ok = run_case(ctx, c, opts, runs, warmup, cpu_threads, flat, quick) && ok;
  }
  if (which == "all" || which == "waymo") {
    const std::string path = data + "/maps/waymo/motion_data_one_scenario.tfrecord";
    if (!std::filesystem::exists(path)) {
      std::printf("\nskip waymo (blocks): %s not found (set ICUBE_TEST_DATA)\n", path.c_str());
    } else {
      const scene::Scene sc = scene::load_scene(path);
      double s = 0.0;
      Case c{"waymo (blocks)", bench::build_procedural(sc, world::PlanMode::Blocks, s), ego_camera(sc, frame)};
      std::printf("\n(waymo world built in %.1f s, not timed below)\n", s);
      ok = run_case(ctx, c, opts, runs, warmup, cpu_threads, flat, quick) && ok;
    }
  }
  return ok ? 0 : 1;
}
