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
#include "scene/scene_load.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace icube;

namespace {

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
  for (const std::string& path : files) {
    try {
      scene::Scene s = scene::load_scene(path, options);  // warm-up
      std::vector<double> ms;
      for (int i = 0; i < runs; ++i) {
        const auto t0 = std::chrono::steady_clock::now();
        s = scene::load_scene(path, options);
        ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      }
      std::sort(ms.begin(), ms.end());
      const size_t layers = s.map.lanes.size() + s.map.road_lines.size() + s.map.road_edges.size();
      const std::string name = path.size() > 52 ? "..." + path.substr(path.size() - 49) : path;
      std::printf("%-52s %6d %9.2f %10.2f %7zu %9zu\n", name.c_str(), runs, ms.front(), ms[ms.size() / 2], layers,
                  map_points(s));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "icube-bench-scene: %s\n", e.what());
      return 1;
    }
  }
  return 0;
}
