// `icube scene plot` (top-down PNG of a scene, engine/scene/map_plot.h) and
// `icube scene route` (a seeded drive along the lanes written as scene JSON,
// engine/scene/route.h). Registered by add_scene_commands() (cmd_scene.cpp).
//
//   icube scene plot FILE -o map.png [--record SEL] [--time S | --frame N] [--width PX] [--bbox X0,Y0,X1,Y1] ...
//   icube scene route FILE -o scene.json [--record SEL] [--length M] [--speed MPS] [--seed N] [--start-lane ID]
//                     [--plot route.png]
//
// Errors print one line, "icube: error: ...", and exit with status 1.
#include "cmd_scene_plot.h"
#include "cli_common.h"

#include "scene/atomic_file.h"
#include "scene/map_plot.h"
#include "scene/route.h"
#include "scene/scene_json.h"
#include "scene/scene_load.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

namespace icube::tools {

namespace {

struct PlotArgs {
  std::string file, record, output, bbox;
  scene::MapPlotOptions plot;
  double time = 0.0;
  int frame = 0;
  bool no_boxes = false, no_ego_path = false, no_legend = false, no_scale_bar = false;
};

struct RouteArgs {
  std::string file, record, output, plot_output;
  scene::RouteOptions route;
  int64_t start_lane = 0;
};


// "X0,Y0,X1,Y1" in metres.
scene::PlotBounds parse_bbox(const std::string& text) {
  std::istringstream in(text);
  double v[4];
  char comma = 0;
  bool ok = static_cast<bool>(in >> v[0]);
  for (int i = 1; i < 4 && ok; ++i) ok = (in >> comma >> v[i]) && comma == ',';
  in >> std::ws;
  if (!ok || !in.eof())
    throw std::invalid_argument("--bbox '" + text + "': expected four numbers X0,Y0,X1,Y1 (metres)");
  return {std::min(v[0], v[2]), std::min(v[1], v[3]), std::max(v[0], v[2]), std::max(v[1], v[3])};
}

void print_plot_written(const std::string& path, const scene::Scene& s, const scene::MapPlot& p) {
  const double mpp = 1.0 / p.view.pixels_per_metre;
  std::printf("wrote %s (%d x %d px, %.0f x %.0f m at %.3g m/px", path.c_str(), p.image.width(), p.image.height(),
              p.view.map_width * mpp, p.view.map_height * mpp, mpp);
  if (p.time_index >= 0)
    std::printf(", t = %.2f s, frame %d", s.timestamps[static_cast<size_t>(p.time_index)], p.time_index);
  std::printf(")\n");
}

void write_plot(const scene::Scene& s, const scene::MapPlotOptions& o, const std::string& path) {
  const scene::MapPlot p = scene::render_map(s, o);
  scene::write_map_png(p, path);
  print_plot_written(path, s, p);
}

void cmd_plot(PlotArgs& a, bool time_given, bool frame_given) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(a.file, a.output);
    scene::MapPlotOptions o = a.plot;
    if (time_given) o.time = a.time;
    if (frame_given) o.time_index = a.frame;
    o.boxes = !a.no_boxes, o.ego_path = !a.no_ego_path, o.legend = !a.no_legend, o.scale_bar = !a.no_scale_bar;
    if (!a.bbox.empty()) o.bounds = parse_bbox(a.bbox);
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    const scene::Scene s = scene::load_scene(a.file, lo, &diag);
    write_plot(s, o, a.output);
  });
}

void cmd_route(RouteArgs& a, bool start_given) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(a.file, a.output);
    if (!a.plot_output.empty()) refuse_overwriting_input(a.file, a.plot_output);
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    const scene::Scene in = scene::load_scene(a.file, lo, &diag);
    scene::RouteOptions ro = a.route;
    if (start_given) ro.start_lane = a.start_lane;
    scene::RouteReport rep;
    const scene::Scene out = scene::sample_route(in, ro, &rep);
    for (const std::string& note : rep.notes) diag.warn(a.file, "route", note);
    const std::string text = scene::scene_to_json(out);
    scene::write_file_atomic(a.output, text);
    std::printf("wrote %s: %zu ego poses at %g Hz over %.1f m along %zu lane(s) at %g m/s (seed %llu), camera %s %ux%u\n",
                a.output.c_str(), rep.poses, ro.rate_hz, rep.length_m, rep.lanes.size(), ro.speed_mps,
                static_cast<unsigned long long>(ro.seed), out.cameras.empty() ? "-" : out.cameras[0].name.c_str(),
                out.cameras.empty() ? 0u : out.cameras[0].width, out.cameras.empty() ? 0u : out.cameras[0].height);
    if (!a.plot_output.empty()) {
      scene::MapPlotOptions po;
      po.time_index = static_cast<int>(out.timestamps.size() / 2);
      write_plot(out, po, a.plot_output);
    }
  });
}

void add_input_options(CLI::App& cmd, std::string& file, std::string& record) {
  cmd.add_option("file", file, "Scene file: icube scene JSON, Waymo Scenario TFRecord, or OpenDRIVE .xodr")
      ->required()
      ->type_name("FILE");
  cmd.add_option("--record", record,
                 "Waymo TFRecord only: which record, by index (0 = first) or scenario id (default: the first)")
      ->type_name("SEL");
}

}  // namespace

void add_scene_plot_commands(CLI::App& scene_cmd) {
  // ---- plot ----
  auto pa = std::make_shared<PlotArgs>();
  CLI::App* plot = scene_cmd.add_subcommand(
      "plot", "Draw a top-down PNG of a scene: map layers by type, object boxes at one time, the ego path, "
              "a legend and a scale bar");
  add_input_options(*plot, pa->file, pa->record);
  plot->add_option("-o,--output", pa->output, "Output PNG path")->required()->type_name("map.png");
  plot->add_option("--width", pa->plot.width, "Image width in pixels; the height follows the map's aspect")
      ->type_name("PX")
      ->check(CLI::Range(320, 16384))
      ->capture_default_str();
  plot->add_option("--max-height", pa->plot.max_height, "Cap on the image height in pixels")
      ->type_name("PX")
      ->check(CLI::Range(240, 16384))
      ->capture_default_str();
  CLI::Option* time = plot->add_option("--time", pa->time,
                                       "Time of the boxes in seconds (nearest timestamp; default: the scene's current "
                                       "time)")
                          ->type_name("SECONDS");
  CLI::Option* frame =
      plot->add_option("--frame", pa->frame, "Time of the boxes as a timestamp index (0 = first)")->type_name("INDEX");
  time->excludes(frame);
  plot->add_option("--bbox", pa->bbox, "World window to draw, in metres (default: everything, plus the margin)")
      ->type_name("X0,Y0,X1,Y1");
  plot->add_option("--margin", pa->plot.margin_m, "Margin around everything drawn, in metres")
      ->type_name("METRES")
      ->check(CLI::Range(0.0, 100000.0))
      ->capture_default_str();
  plot->add_flag("--no-boxes", pa->no_boxes, "Leave out object and ego boxes");
  plot->add_flag("--no-ego-path", pa->no_ego_path, "Leave out the ego path");
  plot->add_flag("--no-legend", pa->no_legend, "Leave out the legend");
  plot->add_flag("--no-scale-bar", pa->no_scale_bar, "Leave out the scale bar and the +y arrow");
  plot->callback([pa, time, frame] { cmd_plot(*pa, time->count() > 0, frame->count() > 0); });

  // ---- route ----
  auto ra = std::make_shared<RouteArgs>();
  CLI::App* route = scene_cmd.add_subcommand(
      "route", "Sample an ego drive along the lanes (for maps without an ego trajectory, e.g. OpenDRIVE) and "
               "write the scene with 10 Hz ego poses and a front camera as icube scene JSON");
  add_input_options(*route, ra->file, ra->record);
  route->add_option("-o,--output", ra->output, "Output path of the scene JSON")->required()->type_name("scene.json");
  route->add_option("--length", ra->route.length_m,
                    "Drive length in metres (less only if no drive that long exists from the start lane)")
      ->type_name("M")
      ->check(CLI::Range(0.1, 1.0e6))
      ->capture_default_str();
  route->add_option("--speed", ra->route.speed_mps, "Constant speed in m/s (poses are speed/10 m apart)")
      ->type_name("MPS")
      ->check(CLI::Range(0.1, 100.0))
      ->capture_default_str();
  route->add_option("--seed", ra->route.seed, "Seed for the start lane and the choice at forks")
      ->type_name("N")
      ->capture_default_str();
  CLI::Option* start =
      route->add_option("--start-lane", ra->start_lane, "Lane id to start on (default: chosen by the seed)")
          ->type_name("ID");
  route->add_option("--plot", ra->plot_output, "Also draw the route to this PNG (boxes at the middle of the drive)")
      ->type_name("route.png");
  route->footer(
      "Lanes connect through their exit lanes (OpenDRIVE: road, lane and junction links) and, where a lane has "
      "none, when it ends within 0.5 m of another's start with headings within 30 degrees. The drive is planned "
      "ahead: the start lane and every fork are drawn among the lanes from which the rest of the length can still "
      "be driven. The camera is the Waymo-FRONT-like preset at 832x480, 1.8 m above the lane centre line.");
  route->callback([ra, start] { cmd_route(*ra, start->count() > 0); });
}

}  // namespace icube::tools
