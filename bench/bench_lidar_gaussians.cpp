// icube-bench-lidar-gs: LiDAR on Gaussians (engine/splat/lidar_gaussians_*.h,
// shaders/splat_lidar_*.comp): the GPU caster (binning + sort + per-ray
// merge) against the CPU reference (every Gaussian for every ray, sorted,
// double) with the same number of threads, in rays per second, on the
// waymo-top preset (64 x 2650 rays).
//
// Scenes: the real 3DGS .ply ($ICUBE_TEST_DATA/splats/pc_short.ply, default
// ../shared/data; skipped when absent), sensor at its centroid; and a random
// scene of --gaussians N Gaussians (fixed seed) in a 120 x 120 x 8 m box
// around the sensor, log-uniform scales 5-50 cm, opacity U(0, 1), plus a
// ground of wide flat Gaussians, sensor 2 m above it.
// GPU: min / median over --runs sweeps after --warmup (whole sweep wall
// clock: two submissions, one CPU sync, hits download) and GPU timestamps by
// phase. CPU: the reference on an evenly spaced subset of --cpu-rays rays
// (rays/s extrapolate linearly: rays are independent), --threads threads
// (default 2 = LP_NUM_THREADS). Correctness in the same run: the GPU's hits
// on that subset against the reference (return flags, median range within
// 1e-3 relative).
//
//   LP_NUM_THREADS=2 icube-bench-lidar-gs [--gaussians 100000] [--runs 5] [--cpu-rays 2000] [--threads 2]
#include "bench_host.h"
#include "gpu/context.h"
#include "render/lidar/lidar_model.h"
#include "splat/lidar_gaussians_cpu.h"
#include "splat/lidar_gaussians_gpu.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

using namespace icube;

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? std::nan("") : v[v.size() / 2];
}

splat::GaussianCloud random_scene(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), u01(0.0, 1.0);
  std::normal_distribution<double> nd(0.0, 1.0);
  splat::GaussianCloud c;
  c.sh_degree = 0;
  float coeffs[3];
  for (size_t i = 0; i < n; ++i) {
    const glm::dvec3 p(60.0 * u(rng), 60.0 * u(rng), 4.0 + 4.0 * u(rng));
    glm::vec3 s;
    for (int k = 0; k < 3; ++k) s[k] = static_cast<float>(std::exp(std::log(0.05) + std::log(10.0) * u01(rng)));
    glm::dvec4 q(nd(rng), nd(rng), nd(rng), nd(rng));
    q /= glm::length(q);
    for (float& x : coeffs) x = static_cast<float>(1.5 * u(rng));
    c.add(p, s, glm::vec4(q), static_cast<float>(u01(rng)), coeffs);
  }
  // Ground z = 0: 2 m grid of 1.5 m wide, 1 cm thick Gaussians over the box.
  for (int i = -30; i <= 30; ++i)
    for (int j = -30; j <= 30; ++j) {
      for (float& x : coeffs) x = -1.0f;
      c.add(glm::dvec3(2.0 * i, 2.0 * j, 0.0), glm::vec3(1.5f, 1.5f, 0.01f), glm::vec4(1, 0, 0, 0), 0.95f, coeffs);
    }
  return c;
}

struct Result {
  std::string scene;
  size_t gaussians = 0;
  double gpu_min_ms = 0, gpu_med_ms = 0, bin_ms = 0, sort_ms = 0, cast_ms = 0;
  uint64_t instances = 0;
  double cpu_ms_per_ray = 0;
  size_t cpu_rays = 0, flag_diff = 0, range_diff = 0, returns = 0;
  double other_cpu_share = 0;
};

Result run_scene(gpu::Context& ctx, const std::string& name, const splat::GaussianCloud& cloud,
                 const glm::dmat4& pose, int runs, int warmup, size_t cpu_rays, unsigned threads) {
  const render::LidarModel m = render::waymo_top_lidar();
  splat::LidarGaussiansGpu caster(ctx, m);
  const std::vector<float> inten = splat::lidar_gaussian_intensity(cloud);
  const splat::GpuLidarGaussians g = caster.upload(cloud, inten);
  Result r;
  r.scene = name;
  r.gaussians = cloud.size();
  const bench::CpuTimes c0 = bench::cpu_times_now();
  std::vector<shader::SplatLidarHit> hits;
  std::vector<double> wall;
  splat::LidarGaussianTimings t;
  std::vector<double> bin, sort, cast;
  for (int k = 0; k < warmup + runs; ++k) {
    const auto t0 = Clock::now();
    hits = caster.cast(g, pose, &t);
    const double ms = ms_since(t0);
    if (k < warmup) continue;
    wall.push_back(ms);
    bin.push_back(t.bin_ms);
    sort.push_back(t.sort_ms);
    cast.push_back(t.cast_ms);
  }
  r.gpu_min_ms = *std::min_element(wall.begin(), wall.end());
  r.gpu_med_ms = median(wall);
  r.bin_ms = median(bin);
  r.sort_ms = median(sort);
  r.cast_ms = median(cast);
  r.instances = t.instances;

  std::vector<uint32_t> subset;
  const size_t total = m.rays();
  const size_t step = std::max<size_t>(1, total / std::max<size_t>(1, cpu_rays));
  for (size_t i = step / 2; i < total; i += step) subset.push_back(static_cast<uint32_t>(i));
  const auto t0 = Clock::now();
  const auto cpu = splat::cast_lidar_gaussians_cpu(cloud, inten, m, pose, threads, subset);
  r.cpu_ms_per_ray = ms_since(t0) / static_cast<double>(subset.size());
  r.cpu_rays = subset.size();
  const bench::CpuTimes c1 = bench::cpu_times_now();
  const double span = c1.wall_s - c0.wall_s;
  r.other_cpu_share = span > 0 ? bench::other_cpu_seconds(c0, c1) / (span * std::max(1u, bench::online_cpus())) : 0.0;
  for (uint32_t i : subset) {
    const auto& a = hits[i];
    const auto& b = cpu[i];
    const bool ra = a.count > 0 && a.alpha >= 0.5f, rb = b.count > 0 && b.alpha >= 0.5f;
    r.returns += rb;
    if (ra != rb) {
      ++r.flag_diff;
      continue;
    }
    if (!ra) continue;
    const double x = (a.flags & SPLAT_LIDAR_FLAG_MEDIAN) ? a.t_median : a.t_expected;
    const double y = (b.flags & SPLAT_LIDAR_FLAG_MEDIAN) ? b.t_median : b.t_expected;
    if (std::fabs(x - y) > 1e-3 * std::fabs(y) + 1e-4 && r.range_diff++ < 5)
      std::printf("  %s ray %u: median/expected gpu %.5f cpu %.5f (alpha %.5f|%.5f, count %u|%u, gpu flags %u)\n",
                  name.c_str(), i, x, y, double(a.alpha), double(b.alpha), a.count, b.count, a.flags);
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("icube-bench-lidar-gs: LiDAR on Gaussians, GPU caster vs CPU reference (rays/s, waymo-top)");
  size_t n = 100000, cpu_rays = 2000;
  int runs = 5, warmup = 1;
  unsigned threads = 2;
  app.add_option("--gaussians", n, "Random scene size (plus a 61 x 61 ground of flat Gaussians); 0 = skip it");
  app.add_option("--runs", runs, "Timed GPU sweeps")->check(CLI::Range(1, 1000));
  app.add_option("--warmup", warmup, "Untimed GPU sweeps first")->check(CLI::Range(0, 100));
  app.add_option("--cpu-rays", cpu_rays, "Rays the CPU reference casts (evenly spaced)")->check(CLI::Range(1, 1000000));
  app.add_option("--threads", threads, "CPU reference threads (match LP_NUM_THREADS)")->check(CLI::Range(1, 256));
  CLI11_PARSE(app, argc, argv);
  try {
    gpu::Context ctx(gpu::ContextOptions::from_env());
    std::printf("icube-bench-lidar-gs: device %s, subgroup %u, CPU %s (%u CPUs), LP_NUM_THREADS=%s, CPU threads %u\n",
                ctx.info().name.c_str(), ctx.subgroup_size(), bench::cpu_model().c_str(), bench::online_cpus(),
                bench::env_or_unset("LP_NUM_THREADS").c_str(), threads);
    std::vector<Result> rows;
    const char* env = std::getenv("ICUBE_TEST_DATA");
    const std::string ply = std::string(env && *env ? env : "../shared/data") + "/splats/pc_short.ply";
    if (std::filesystem::exists(ply)) {
      const auto cloud = splat::read_gaussians_ply(ply);
      const auto s = splat::summarize(cloud);
      glm::dmat4 pose(1.0);
      pose[3] = glm::dvec4(s.centroid, 1.0);
      rows.push_back(run_scene(ctx, "pc_short.ply", cloud, pose, runs, warmup, cpu_rays, threads));
    } else {
      std::printf("real scene skipped: %s not found\n", ply.c_str());
    }
    if (n > 0) {
      glm::dmat4 pose(1.0);
      pose[3] = glm::dvec4(0.3, -0.2, 2.0, 1.0);
      rows.push_back(run_scene(ctx, "random " + std::to_string(n), random_scene(n, 42), pose, runs, warmup, cpu_rays,
                               threads));
    }
    const double rays = static_cast<double>(render::waymo_top_lidar().rays());
    std::printf("%-16s %9s %10s %10s %9s %9s %9s %11s %12s %12s %8s %7s %7s %6s\n", "scene", "gaussians", "gpu min ms",
                "gpu med ms", "bin ms", "sort ms", "cast ms", "instances", "gpu Mrays/s", "cpu Mrays/s", "gpu/cpu",
                "cpu n", "check", "other");
    for (const Result& r : rows) {
      const double g = rays / (r.gpu_med_ms * 1e3), c = 1e-3 / r.cpu_ms_per_ray;
      const bool ok = r.flag_diff <= r.cpu_rays / 200 && r.range_diff <= r.cpu_rays / 200;
      std::printf("%-16s %9zu %10.1f %10.1f %9.1f %9.1f %9.1f %11llu %12.3f %12.4f %8.1f %7zu %7s %5.0f%%\n",
                  r.scene.c_str(), r.gaussians, r.gpu_min_ms, r.gpu_med_ms, r.bin_ms, r.sort_ms, r.cast_ms,
                  static_cast<unsigned long long>(r.instances), g, c, g / c, r.cpu_rays, ok ? "ok" : "FAIL",
                  100.0 * r.other_cpu_share);
      if (!ok)
        std::printf("  %s: %zu of %zu checked rays differ in the return flag, %zu in range\n", r.scene.c_str(),
                    r.flag_diff, r.cpu_rays, r.range_diff);
    }
    std::printf("gpu: whole sweep (%.0f rays) wall clock incl. hit download, median of %d; phases: GPU timestamps "
                "(median). cpu: reference on the checked subset, same threads. other: CPU share other processes "
                "took during the scene's runs.\n",
                rays, runs);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "icube-bench-lidar-gs: %s\n", e.what());
    return 1;
  }
  return 0;
}
