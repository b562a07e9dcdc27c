// icube-bench-scene: time reading scene files (parse + sample + derive layers).
//
//   icube-bench-scene [FILE ...] [--runs N] [--step M]
//
// Without files it times the two real inputs the scene issue names:
// $ICUBE_TEST_DATA (default ../shared/data)/maps/opendrive/carla/Town07.xodr
// (1.7 MB OpenDRIVE: XML parse, reference-line evaluation, sampling at
// --step, lane lines, road edges, junction union edges) and
// maps/waymo/motion_data_one_scenario.tfrecord (framing + CRC32C + protobuf
// decode). One warm-up, then N >= 5 timed runs of scene::load_scene each;
// prints a table with min and median wall-clock milliseconds and what was read.
// Then a "road surface" row per file and configuration: the road-surface fit
// (world/road_surface.h) of the loaded map at cell 0.4 m (upstream's), and at
// 0.2 m with segment barriers and seed margin 10 m (the procedural prior's),
// one warm-up and N timed fits each, min and median milliseconds.
#include "scene/scene_load.h"
#include "world/road_surface.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

using namespace icube;

namespace {

// min and median of the timed runs of `f` (one warm-up first), in milliseconds.
template <class F>
std::pair<double, double> time_runs(int runs, F&& f) {
  f();
  std::vector<double> ms;
  for (int i = 0; i < runs; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return {ms.front(), ms[ms.size() / 2]};
}

size_t map_points(const scene::Scene& s) {
  size_t n = 0;
  for (const auto& l : s.map.lanes) n += l.points.size();
  for (const auto& l : s.map.road_lines) n += l.points.size();
  for (const auto& e : s.map.road_edges) n += e.points.size();
  for (const auto& p : s.map.crosswalks) n += p.points.size();
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Time scene loading (OpenDRIVE, Waymo TFRecord, JSON): parse + sample, min/median of N runs",
               "icube-bench-scene"};
  std::vector<std::string> files;
  int runs = 7;
  double step = 0.25;
  app.add_option("files", files, "Scene files (default: Town07.xodr and the Waymo scenario from the test data)");
  app.add_option("--runs", runs, "Timed runs per file (at least 5)")->check(CLI::Range(5, 1000));
  app.add_option("--step", step, "OpenDRIVE sampling step in metres")->check(CLI::Range(0.01, 100.0));
  CLI11_PARSE(app, argc, argv);
  if (files.empty()) {
    const char* env = std::getenv("ICUBE_TEST_DATA");
    const std::string data = env && *env ? env : "../shared/data";
    files = {data + "/maps/opendrive/carla/Town07.xodr", data + "/maps/waymo/motion_data_one_scenario.tfrecord"};
  }
  scene::LoadOptions options;
  options.opendrive.sample_step = step;
  std::printf("%-52s %6s %9s %10s %7s %9s\n", "file", "runs", "min ms", "median ms", "layers", "points");
  std::vector<scene::Map> maps;
  for (const std::string& path : files) {
    try {
      scene::Scene s;
      const auto [min_ms, median_ms] = time_runs(runs, [&]() { s = scene::load_scene(path, options); });
      const size_t layers = s.map.lanes.size() + s.map.road_lines.size() + s.map.road_edges.size();
      const std::string name = path.size() > 52 ? "..." + path.substr(path.size() - 49) : path;
      std::printf("%-52s %6d %9.2f %10.2f %7zu %9zu\n", name.c_str(), runs, min_ms, median_ms, layers, map_points(s));
      maps.push_back(std::move(s.map));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "icube-bench-scene: %s\n", e.what());
      return 1;
    }
  }

  // road surface: the fit of each loaded map, upstream's cell and the procedural prior's configuration.
  std::printf("\n%-36s %-15s %6s %9s %10s %7s %9s\n", "road surface", "config", "runs", "min ms", "median ms", "blocks",
              "points");
  for (size_t f = 0; f < files.size(); ++f) {
    world::RoadSurfaceOptions fine;
    fine.cell = 0.2;
    fine.barrier_segments = true;
    fine.seed_margin = 10.0;
    const std::pair<const char*, world::RoadSurfaceOptions> configs[] = {{"0.4", {}}, {"0.2 seg m10", fine}};
    const std::string& path = files[f];
    const std::string name = path.size() > 36 ? "..." + path.substr(path.size() - 33) : path;
    for (const auto& [label, o] : configs) {
      try {
        world::RoadSurface surface;
        const auto [min_ms, median_ms] = time_runs(runs, [&]() { surface = world::build_road_surface(maps[f], o); });
        std::printf("%-36s %-15s %6d %9.2f %10.2f %7zu %9zu\n", name.c_str(), label, runs, min_ms, median_ms,
                    surface.blocks().size(), surface.kept_cells());
      } catch (const std::exception& e) {
        std::fprintf(stderr, "icube-bench-scene: road surface: %s\n", e.what());
        return 1;
      }
    }
  }
  return 0;
}
