// `icube conditions SCENE --chunk K -o cond.npy [--time-index T] [--cpu]`:
// the Stage-1 condition volume of one trajectory chunk (conventions §7) as a
// float32 .npy of shape [8, 64, 64, 64] (channels i, j, k, road_edge,
// road_line, road_surface, sin θ, cos θ; engine/world/conditions.h), plus
// cond.png next to it: top-down views of road_edge, road_line, road_surface
// (max over k) and of the box channels (topmost lit cell, hue = heading).
// Image up = chunk +x (forward), image right = chunk -y (right). The chunk
// pose comes from world::plan_trajectory (engine/world/chunk_plan.h); the
// road_surface channel from the scene's fitted road surface
// (engine/world/road_surface.h, 0.4 m cells), fitted once here.
#include "cli_common.h"
#include "command_registry.h"

#include "gpu/context.h"
#include "scene/png_write.h"
#include "scene/scene_load.h"
#include "world/chunk_plan.h"
#include "world/conditions.h"
#include "world/conditions_gpu.h"
#include "world/npy.h"
#include "world/road_surface.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace icube::tools {

namespace {

struct ConditionsArgs {
  std::string file;
  std::string output = "cond.npy";
  std::string record;
  int chunk = 0;
  int time_index = 0;
  bool cpu = false;
};

constexpr int kScale = 4;  // pixels per latent cell in the PNG
constexpr int kPanel = world::kLatentDim * kScale;
constexpr int kGap = 4;

// 2 x 2 panels: road_edge, road_line / road_surface, boxes.
std::vector<uint8_t> render_png(const std::vector<float>& vol, int& width, int& height) {
  width = height = 2 * kPanel + kGap;
  std::vector<uint8_t> rgb(static_cast<size_t>(width) * static_cast<size_t>(height) * 3, 64);
  const int n = world::kLatentDim;
  auto put = [&](int panel, int x, int y, uint8_t r, uint8_t g, uint8_t b) {
    const int px0 = (panel % 2) * (kPanel + kGap) + (n - 1 - y) * kScale;
    const int py0 = (panel / 2) * (kPanel + kGap) + (n - 1 - x) * kScale;
    for (int dy = 0; dy < kScale; ++dy)
      for (int dx = 0; dx < kScale; ++dx) {
        uint8_t* p = &rgb[(static_cast<size_t>(py0 + dy) * static_cast<size_t>(width) + static_cast<size_t>(px0 + dx)) * 3];
        p[0] = r, p[1] = g, p[2] = b;
      }
  };
  const int map_channels[3] = {world::kCondRoadEdge, world::kCondRoadLine, world::kCondRoadSurface};
  const uint8_t colours[3][3] = {{255, 80, 60}, {255, 230, 60}, {120, 170, 255}};
  for (int x = 0; x < n; ++x)
    for (int y = 0; y < n; ++y) {
      for (int m = 0; m < 3; ++m) {
        bool lit = false;
        for (int z = 0; z < n && !lit; ++z) lit = vol[world::cond_index(map_channels[m], x, y, z)] != 0.0f;
        if (lit) put(m, x, y, colours[m][0], colours[m][1], colours[m][2]);
        else put(m, x, y, 0, 0, 0);
      }
      put(3, x, y, 0, 0, 0);
      for (int z = n - 1; z >= 0; --z) {
        const double s = vol[world::cond_index(world::kCondSin, x, y, z)];
        const double c = vol[world::cond_index(world::kCondCos, x, y, z)];
        if (s == 0.0 && c == 0.0) continue;
        auto ch = [](double v) { return static_cast<uint8_t>(std::lround(127.5 + 127.0 * v)); };
        put(3, x, y, ch(c), ch(s), ch(-0.5 * (c + s)));
        break;
      }
    }
  return rgb;
}

void print_surface_summary(const world::RoadSurface& surface) {
  size_t split = 0, fallback = 0;
  for (const world::SurfaceBlock& b : surface.blocks()) split += b.split, fallback += !b.plane_fitted;
  std::printf("road surface: %zu block(s) of %.0f m (%zu split, %zu horizontal fallback), %zu cells of %.1f m\n",
              surface.blocks().size(), surface.options().block_size, split, fallback, surface.kept_cells(),
              surface.options().cell);
}

void cmd_conditions(const ConditionsArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    scene::Scene s = scene::load_scene(a.file, lo, &diag);
    scene::classify_tracks(s);
    const world::ChunkPlan plan = world::plan_trajectory(s);
    if (a.chunk < 0 || static_cast<size_t>(a.chunk) >= plan.chunks.size())
      throw std::invalid_argument("--chunk " + std::to_string(a.chunk) + " out of range: the plan has " +
                                  std::to_string(plan.chunks.size()) + " chunks");
    if (!s.timestamps.empty() && (a.time_index < 0 || static_cast<size_t>(a.time_index) >= s.timestamps.size()))
      throw std::invalid_argument("--time-index out of range [0, " + std::to_string(s.timestamps.size()) + ")");
    world::ConditionOptions opts;
    opts.time_index = a.time_index;
    const world::RoadSurface surface = world::build_road_surface(s.map, opts.surface);
    print_surface_summary(surface);
    const world::ConditionInputs in =
        world::gather_condition_inputs(s, plan.chunks[static_cast<size_t>(a.chunk)], surface, opts);
    std::vector<float> vol;
    if (a.cpu) {
      vol = world::build_conditions_cpu(in);
    } else {
      gpu::Context ctx(gpu::ContextOptions::from_env());
      world::ConditionVolumeGpu gpu_cond(ctx);
      vol = gpu_cond.build(in);
    }
    const uint64_t n = world::kLatentDim;
    world::write_npy(a.output, world::NpyArray::make<float>({world::kCondChannels, n, n, n}, vol));
    int w = 0, h = 0;
    const std::vector<uint8_t> rgb = render_png(vol, w, h);
    const std::string png = std::filesystem::path(a.output).replace_extension(".png").string();
    scene::write_png(png, rgb.data(), w, h, 3);
    size_t counts[world::kCondChannels] = {};
    for (int c = 3; c < world::kCondChannels; ++c)
      for (size_t i = 0; i < world::kCondVoxels; ++i) counts[c] += vol[static_cast<size_t>(c) * world::kCondVoxels + i] != 0.0f;
    std::printf("chunk %d (%s), time index %d: %zu road-edge, %zu road-line, %zu road-surface points; %zu static cars\n",
                a.chunk, world::chunk_kind_name(plan.info[static_cast<size_t>(a.chunk)].kind), a.time_index,
                in.edge_grid.size(), in.line_grid.size(), in.surface_grid.size(), in.boxes.size());
    std::printf("lit cells: road_edge %zu, road_line %zu, road_surface %zu, boxes %zu\n", counts[3], counts[4],
                counts[5], std::max(counts[6], counts[7]));
    std::printf("wrote %s [8, 64, 64, 64] float32 (%s) and %s\n", a.output.c_str(), a.cpu ? "CPU" : "GPU", png.c_str());
  });
}

void add_conditions_commands(CLI::App& app) {
  auto args = std::make_shared<ConditionsArgs>();
  CLI::App* cmd = app.add_subcommand(
      "conditions", "Stage-1 condition volume of one chunk: [8,64,64,64] float32 .npy (i, j, k, road_edge, road_line, "
                    "road_surface, sin, cos) and a PNG view");
  cmd->add_option("file", args->file, "Scene file: icube scene JSON, Waymo Scenario TFRecord, or OpenDRIVE .xodr")
      ->required();
  cmd->add_option("--chunk", args->chunk, "Trajectory chunk index (icube world plan)")->default_val(0);
  cmd->add_option("-o,--output", args->output, "Output .npy (the PNG goes next to it, same stem)")->default_val("cond.npy");
  cmd->add_option("--time-index", args->time_index, "Timestamp index of the static car boxes")->default_val(0);
  cmd->add_option("--record", args->record, "Waymo: which record/scenario of the file");
  cmd->add_flag("--cpu", args->cpu, "Use the CPU reference instead of the GPU kernels");
  cmd->callback([args] { cmd_conditions(*args); });
}

}  // namespace

static const CommandRegistrar kConditionsRegistrar(add_conditions_commands, 40);

}  // namespace icube::tools
