// icube-bench-world: time the Stage-1 world build (plan + procedural prior +
// fusion + static vehicles, engine/world/world_build.h) side by side with 1
// and 2 generator threads.
//
//   icube-bench-world [--runs N] [--data DIR] [--threads-max N]
//
// Cases: the embedded demo scene (trajectory and blocks mode), the Waymo
// scenario and CARLA Town07 (blocks mode) from $ICUBE_TEST_DATA (default
// ../shared/data; skipped when absent). Each case: one warm-up build, then N
// >= 5 timed builds per thread count; min and median wall time, chunks/s,
// Mvoxels/s, world memory, the region the plan covers and the process's peak
// RSS. Correctness in the same run: every thread count gives byte-identical
// world files, and no voxel other than road, lane marker or a vehicle lies
// in a drivable column.
#include "scene/scene_load.h"
#include "world/demo_scene.h"
#include "world/procedural/procedural_prior.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

using namespace icube;

namespace {

struct Case {
  std::string name;
  scene::Scene scene;
  world::PlanMode mode;
};

double peak_rss_mib() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_maxrss) / 1024.0;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// Width x height (metres) of the bounding box of the plan's chunk footprints.
glm::dvec2 plan_extent(const world::ChunkPlan& plan) {
  glm::dvec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const auto& c : plan.chunks)
    for (const glm::dvec2& p : world::chunk_footprint(c)) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  return plan.chunks.empty() ? glm::dvec2(0.0) : hi - lo;
}

// Voxels in drivable columns that are not road, lane marker or vehicle.
uint64_t drivable_violations(const world::VoxelGrid& g, const world::RoadSurface& surface) {
  uint64_t bad = 0;
  g.for_each_voxel([&](const glm::ivec3& ijk, const world::Voxel& v) {
    if (v.class_id == 18 || v.class_id == 19 || world::is_vehicle_class(v.class_id)) return;
    const glm::dvec3 p = g.ijk_to_world(ijk);
    if (surface.drivable(p.x, p.y)) ++bad;
  });
  return bad;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Time the Stage-1 world build (procedural prior) with 1 and 2 threads; min/median of N runs",
               "icube-bench-world"};
  int runs = 5, threads_max = 2;
  std::string data;
  app.add_option("--runs", runs, "Timed builds per case and thread count (at least 5)")->check(CLI::Range(5, 1000));
  app.add_option("--threads-max", threads_max, "Largest thread count (1 and this are compared)")
      ->check(CLI::Range(1, 256));
  app.add_option("--data", data, "Test data directory (default $ICUBE_TEST_DATA or ../shared/data)");
  CLI11_PARSE(app, argc, argv);
  if (data.empty()) {
    const char* env = std::getenv("ICUBE_TEST_DATA");
    data = env && *env ? env : "../shared/data";
  }
  std::vector<Case> cases;
  cases.push_back({"demo (trajectory)", world::make_demo_scene(), world::PlanMode::Trajectory});
  cases.push_back({"demo (blocks)", world::make_demo_scene(), world::PlanMode::Blocks});
  for (const auto& [name, rel] : {std::pair<std::string, std::string>{"waymo scenario (blocks)",
                                                                       "/maps/waymo/motion_data_one_scenario.tfrecord"},
                                  {"Town07 (blocks)", "/maps/opendrive/carla/Town07.xodr"}}) {
    if (!std::filesystem::exists(data + rel)) {
      std::printf("skip %s: %s%s not found (set ICUBE_TEST_DATA)\n", name.c_str(), data.c_str(), rel.c_str());
      continue;
    }
    cases.push_back({name, scene::load_scene(data + rel), world::PlanMode::Blocks});
  }
  std::vector<int> thread_counts = {1};
  if (threads_max > 1) thread_counts.push_back(threads_max);

  std::printf("\n%-24s %3s %7s %11s %9s %10s %9s %9s %10s %9s %6s\n", "case", "thr", "chunks", "region m", "min s",
              "median s", "chunks/s", "Mvox/s", "voxels", "MiB", "check");
  bool all_ok = true;
  for (const Case& c : cases) {
    const auto t_prior = std::chrono::steady_clock::now();
    const world::ProceduralPrior prior(c.scene);
    const double prior_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_prior).count();
    std::string reference_bytes;
    for (int threads : thread_counts) {
      world::WorldBuildOptions o;
      o.mode = c.mode;
      o.threads = threads;
      world::WorldBuildResult r = world::build_world(c.scene, prior, o);  // warm-up
      std::vector<double> s;
      for (int i = 0; i < runs; ++i) {
        r = world::build_world(c.scene, prior, o);
        s.push_back(r.total_s);
      }
      const std::string bytes = world::world_to_bytes(r.world);
      if (reference_bytes.empty()) reference_bytes = bytes;
      const uint64_t bad = drivable_violations(r.world, prior.road_surface());
      const bool ok = bytes == reference_bytes && bad == 0;
      all_ok = all_ok && ok;
      const double mn = *std::min_element(s.begin(), s.end()), md = median(s);
      const glm::dvec2 ext = plan_extent(r.plan);
      char region[32];
      std::snprintf(region, sizeof region, "%.0fx%.0f", ext.x, ext.y);
      std::printf("%-24s %3d %7zu %11s %9.3f %10.3f %9.1f %9.2f %10llu %9.1f %6s\n", c.name.c_str(), threads,
                  r.plan.chunks.size(), region, mn, md, static_cast<double>(r.plan.chunks.size()) / md,
                  static_cast<double>(r.world.voxel_count()) / md * 1e-6,
                  static_cast<unsigned long long>(r.world.voxel_count()),
                  static_cast<double>(r.world.memory_bytes()) / (1024.0 * 1024.0), ok ? "ok" : "FAIL");
      if (bad) std::printf("  FAIL: %llu non-road voxels in drivable columns\n", static_cast<unsigned long long>(bad));
      if (bytes != reference_bytes) std::printf("  FAIL: world differs from the 1-thread build\n");
    }
    std::printf("  (%s: prior set-up %.3f s once per scene, not in the times above)\n", c.name.c_str(), prior_s);
  }
  std::printf("\npeak RSS %.0f MiB\n", peak_rss_mib());
  return all_ok ? 0 : 1;
}
