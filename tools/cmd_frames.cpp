// `icube frames` (Stage 2 appearance): the frames Stage 3 lifts, from the
// built-in procedural appearance renderer or from a video model run elsewhere.
//
//   icube frames render WORLD [--scene SCENE | --trajectory F | --route M] [--frames A:B[:S]]
//                       [--prompt TEXT] [--seed N] [--camera ... | --camera-preset NAME]
//                       [--no-shadows] [--no-ao] [--pixel-centres] -o FRAMES_DIR
//   icube frames render --list-prompts
//   icube frames sheet WORLD --scene SCENE [--frame K] [--prompt TEXT]... -o SHEET.png
//   icube frames import DIR|VIDEO.mp4 --buffers CLIP_DIR -o FRAMES_DIR
//
// Layout of FRAMES_DIR: engine/render/appearance/frames_layout.h. The same
// trajectory and frame selection as `icube buffers` give frames with the same
// numbers. FRAMES_DIR is built in a hidden staging folder beside it and
// renamed into place at the end: an error leaves nothing half-written.
// Engine: engine/render/appearance/.
#include "camera_path_options.h"
#include "cli_common.h"
#include "command_registry.h"
#include "progress.h"
#include "staging_dir.h"

#include "gpu/context.h"
#include "render/appearance/frames_import.h"
#include "render/appearance/frames_render.h"
#include "render/appearance/lighting.h"
#include "render/appearance/prompt_sheet.h"
#include "render/buffers/contact_sheet.h"
#include "render/buffers/dynamic_cars.h"
#include "render/buffers/frame_scene.h"
#include "render/buffers/overlay_world.h"
#include "world/car_mesh.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

namespace icube::tools {

namespace {

namespace fs = std::filesystem;

struct FramesRenderArgs {
  pipeline::CameraPathArgs path;
  std::string world, prompt = render::kDefaultAppearancePrompt, output;
  uint32_t seed = 0;
  bool no_shadows = false, no_ao = false, pixel_centres = false, list_prompts = false;
  unsigned threads = 0;
};

struct FramesSheetArgs {
  pipeline::CameraPathArgs path;
  std::string world, output;
  std::vector<std::string> prompts;
  int frame = -1, thumb_width = 416, columns = 3;
  uint32_t seed = 0;
};

struct FramesImportArgs {
  std::string input, buffers, output, prompt, sky_masks;
  int sky_label = -1;
};

void report_prompt(const render::AppearancePrompt& p, scene::Diagnostics& diag) {
  std::fprintf(stderr, "prompt: %s\n", p.summary().c_str());
  if (!p.unknown.empty()) {
    std::string u;
    for (const std::string& w : p.unknown) u += (u.empty() ? "" : ", ") + w;
    diag.warn("--prompt", "", "words not understood (see `icube frames render --list-prompts`): " + u);
  }
  for (const std::string& n : p.notes) diag.warn("--prompt", "", n);
}

// The world with the scene's vehicles replaced by its cars (as the guidance buffers).
world::VoxelGrid static_world_of(const world::VoxelGrid& world, const pipeline::CameraPath& cp, const world::TriangleMesh& mesh) {
  if (!cp.scene) return world;
  const render::Trajectory& t = cp.passes[0];
  const int t0 = t.time_index.empty() ? 0 : std::max(0, t.time_index[0]);
  return render::make_static_world(world, *cp.scene, t0, mesh);
}

void cmd_frames_render(const FramesRenderArgs& a) {
  if (a.list_prompts) {
    for (const std::string& l : render::prompt_vocabulary()) std::printf("%s\n", l.c_str());
    return;
  }
  run_command([&](scene::Diagnostics& diag) {
    using Clock = std::chrono::steady_clock;
    const auto t_start = Clock::now();
    if (a.world.empty()) throw std::invalid_argument("give the WORLD file (or --list-prompts)");
    if (a.output.empty()) throw std::invalid_argument("give -o FRAMES_DIR");
    refuse_overwriting_input(a.world, a.output);
    const render::AppearancePrompt parsed = render::parse_prompt(a.prompt);
    report_prompt(parsed, diag);
    const world::VoxelGrid world = world::load_world(a.world);
    pipeline::CameraPath cp = pipeline::resolve_camera_path(a.path, diag);
    const world::TriangleMesh mesh = world::builtin_car_mesh();
    const world::VoxelGrid stat = static_world_of(world, cp, mesh);
    gpu::Context ctx(gpu::ContextOptions::from_env());
    render::OverlayWorld overlay(ctx, stat);
    const fs::path final_dir = fs::absolute(a.output);
    StagingDir staging(final_dir.parent_path(), final_dir.filename().string());
    ProgressBar bar("frames", "frames");
    const size_t total = cp.total_frames();
    size_t before = 0;
    render::FramesRenderStats sum;
    for (size_t p = 0; p < cp.passes.size(); ++p) {
      const fs::path dir = cp.passes.size() > 1 ? staging.path / ("pass_" + std::to_string(p)) : staging.path;
      fs::create_directories(dir);
      render::FramesRenderOptions o;
      o.appearance.shadows = !a.no_shadows;
      o.appearance.ambient_occlusion = !a.no_ao;
      o.appearance.pixels = a.pixel_centres ? render::PixelConvention::Centre : render::PixelConvention::Integer;
      o.seed = a.seed;
      o.threads = a.threads;
      o.progress = [&](size_t done, size_t) { bar.update(before + done, total); };
      const render::FramesRenderStats st = render::render_frames(
          ctx, overlay, stat, cp.scene ? &*cp.scene : nullptr, mesh, cp.K, cp.passes[p], a.prompt, o, dir.string());
      before += cp.passes[p].size();
      sum.frames += st.frames;
      sum.render_s += st.render_s;
      sum.cars_s += st.cars_s;
      sum.write_s += st.write_s;
      sum.lamps = st.lamps;
      sum.max_lights = std::max(sum.max_lights, st.max_lights);
    }
    staging.move_into_place(final_dir);
    const double total_s = std::chrono::duration<double>(Clock::now() - t_start).count();
    std::printf("frames: %zu frames %ux%u (%s), %.2f s, %.2f frames/s rendering [render %.2f s, cars %.2f s, "
                "waiting on PNG writes %.2f s], %zu street lamps, up to %zu lights -> %s\n",
                sum.frames, cp.K.width, cp.K.height, parsed.summary().c_str(), total_s,
                sum.render_s > 0 ? static_cast<double>(sum.frames) / sum.render_s : 0.0, sum.render_s, sum.cars_s,
                sum.write_s, sum.lamps, sum.max_lights, final_dir.string().c_str());
  });
}

void cmd_frames_sheet(const FramesSheetArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(a.world, a.output);
    const std::vector<std::string> prompts = a.prompts.empty() ? render::default_sheet_prompts() : a.prompts;
    const world::VoxelGrid world = world::load_world(a.world);
    pipeline::CameraPath cp = pipeline::resolve_camera_path(a.path, diag);
    const render::Trajectory& t = cp.passes[0];
    const size_t f = a.frame >= 0 ? static_cast<size_t>(a.frame) : t.size() / 2;
    if (f >= t.size())
      throw std::invalid_argument("--frame " + std::to_string(a.frame) + " is past the trajectory's " +
                                  std::to_string(t.size()) + " frames");
    const world::TriangleMesh mesh = world::builtin_car_mesh();
    const world::VoxelGrid stat = static_world_of(world, cp, mesh);
    gpu::Context ctx(gpu::ContextOptions::from_env());
    render::OverlayWorld overlay(ctx, stat);
    render::DynamicCarOverlay cars(overlay, cp.scene ? &*cp.scene : nullptr, mesh);
    render::DynamicCarCosts costs;
    cars.set_time(t.time_index[f], costs);
    render::AppearanceRendererGpu renderer(ctx);
    render::Camera cam;
    cam.K = cp.K;
    cam.c2w = t.c2w[f];
    std::vector<std::pair<std::string, render::AppearanceImage>> tiles;
    std::vector<render::WorldLight> lamps;
    bool lamps_built = false;
    ProgressBar bar("sheet", "prompts");
    for (size_t i = 0; i < prompts.size(); ++i) {
      const render::AppearancePrompt p = render::parse_prompt(prompts[i]);
      report_prompt(p, diag);
      if (render::lamps_on(p) && !lamps_built) lamps = render::street_lamps(stat), lamps_built = true;
      const std::vector<render::WorldLight> lights =
          render::frame_lights(p, lamps, cp.scene ? &*cp.scene : nullptr, t.time_index[f]);
      tiles.emplace_back(p.summary(), renderer.render(overlay.world(), cam, render::lighting_params(p, a.seed), lights,
                                                      render::AppearanceOptions{}));
      bar.update(i + 1, prompts.size());
    }
    const std::string title = fs::path(a.world).filename().string() + ", frame " + std::to_string(t.frame_index[f]) +
                              ": the procedural appearance renderer under " + std::to_string(prompts.size()) + " prompts";
    render::write_contact_sheet(a.output, render::prompt_sheet(tiles, title, a.columns, a.thumb_width));
    std::printf("sheet: %zu prompts, frame %d, %ux%u -> %s\n", prompts.size(), t.frame_index[f], cp.K.width, cp.K.height,
                a.output.c_str());
  });
}

void cmd_frames_import(const FramesImportArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(a.input, a.output);
    const fs::path final_dir = fs::absolute(a.output);
    StagingDir staging(final_dir.parent_path(), final_dir.filename().string());
    render::FramesImportOptions o;
    o.prompt = a.prompt;
    o.sky_masks = a.sky_masks;
    o.sky_label = a.sky_label;
    const render::FramesImportReport rep = render::import_frames(a.input, a.buffers, staging.path.string(), o);
    for (const std::string& n : rep.notes) diag.warn(a.input, "", n);
    staging.move_into_place(final_dir);
    std::printf("import: %zu frames %ux%u%s -> %s\n", rep.frames, rep.width, rep.height,
                rep.rescaled ? " (rescaled)" : "", final_dir.string().c_str());
    if (!a.sky_masks.empty())
      std::printf("import: sky pixels %zu from the masks, %zu in the buffers (%+.2f %% of all pixels not sky by the "
                  "masks: what the video model drew beyond the voxel world, or disagreement)\n",
                  rep.sky_pixels_masks, rep.sky_pixels_buffers,
                  100.0 * (double(rep.sky_pixels_buffers) - double(rep.sky_pixels_masks)) /
                      double(std::max<size_t>(1, rep.frames * rep.width * rep.height)));
  });
}

void add_frames_commands(CLI::App& app) {
  CLI::App* frames = app.add_subcommand(
      "frames", "Stage 2 appearance frames: the procedural renderer, or frames from a video model run elsewhere");
  frames->require_subcommand(1);

  auto r = std::make_shared<FramesRenderArgs>();
  CLI::App* render_cmd = frames->add_subcommand(
      "render", "Render RGB frames of a voxel world along a trajectory with the procedural appearance renderer");
  render_cmd->add_option("world", r->world, "World file (.icw)")->type_name("WORLD");
  add_camera_path_options(render_cmd, r->path);
  render_cmd->add_option("--prompt", r->prompt, "Text prompt: time of day, weather, season (see --list-prompts)")
      ->type_name("TEXT")
      ->capture_default_str();
  render_cmd->add_option("--seed", r->seed, "Seed of the procedural detail (facade colours, lit windows, car paint)")
      ->type_name("N")
      ->capture_default_str();
  render_cmd->add_flag("--no-shadows", r->no_shadows, "No shadow rays (the sun lights every face turned to it)");
  render_cmd->add_flag("--no-ao", r->no_ao, "No ambient occlusion probes");
  render_cmd->add_flag("--pixel-centres", r->pixel_centres, "Rays through pixel centres instead of InfiniCube's integer pixels");
  render_cmd->add_flag("--list-prompts", r->list_prompts, "List the prompt words understood and what each sets, then exit");
  render_cmd->add_option("--threads", r->threads, "PNG encoder threads (0 = all cores)")->capture_default_str();
  render_cmd->add_option("-o,--output", r->output, "Frames folder (rgb/, sky_mask/, instance/, frames_meta.json)")
      ->type_name("FRAMES_DIR");
  render_cmd->footer(
      "A non-learned stand-in for InfiniCube's video model: per-class materials with detail fixed to the world, "
      "Preetham sky and sun with shadow rays, ambient occlusion, street lamps and headlights at night, wet, foggy and "
      "snowy looks. Frames are numbered as `icube buffers` numbers them for the same trajectory and --frames.");
  render_cmd->callback([r] { cmd_frames_render(*r); });

  auto s = std::make_shared<FramesSheetArgs>();
  CLI::App* sheet = frames->add_subcommand("sheet", "Contact sheet PNG of one view under several prompts");
  sheet->add_option("world", s->world, "World file (.icw)")->required()->type_name("WORLD");
  add_camera_path_options(sheet, s->path);
  sheet->add_option("--frame", s->frame, "Frame of the (selected) trajectory (default: the middle one)")->type_name("K");
  sheet->add_option("--prompt", s->prompts,
                    "A prompt per tile (repeat; default: sunny noon, overcast, rainy, foggy, dusk, snowy night)")
      ->type_name("TEXT");
  sheet->add_option("--seed", s->seed, "Seed of the procedural detail")->capture_default_str();
  sheet->add_option("--thumb-width", s->thumb_width, "Tile width in pixels")->capture_default_str()->check(CLI::Range(16, 4096));
  sheet->add_option("--columns", s->columns, "Tiles per row")->capture_default_str()->check(CLI::Range(1, 16));
  sheet->add_option("-o,--output", s->output, "Sheet PNG")->required()->type_name("SHEET.png");
  sheet->callback([s] { cmd_frames_sheet(*s); });

  auto i = std::make_shared<FramesImportArgs>();
  CLI::App* imp = frames->add_subcommand(
      "import", "Import frames made by a video model from our guidance buffers (PNG folder or mp4) as a frames folder");
  imp->add_option("input", i->input, "Folder of PNG frames (sorted by name) or an .mp4")->required()->type_name("DIR|VIDEO");
  imp->add_option("--buffers", i->buffers, "The guidance-buffer clip folder the frames were made from (icube buffers)")
      ->required()
      ->type_name("CLIP_DIR");
  imp->add_option("--prompt", i->prompt, "The prompt the video model was given (recorded in frames_meta.json)")->type_name("TEXT");
  add_sky_mask_options(imp, i->sky_masks, i->sky_label, "the frames");
  imp->add_option("-o,--output", i->output, "Frames folder")->required()->type_name("FRAMES_DIR");
  imp->footer(
      "Frames are matched to the buffers' frames by index: the count must equal the buffers' frame count; a different "
      "size with the same aspect ratio is rescaled to the buffers' size, another aspect ratio is refused. sky_mask/ comes "
      "from the buffers (semantic sky colour) or from --sky-masks, instance/ from the buffers' instance_buffer tar. "
      "Only segmented sky masks let `icube lift` place Gaussians for what the video model drew beyond the voxel world.");
  imp->callback([i] { cmd_frames_import(*i); });
}

const CommandRegistrar kFramesRegistrar(add_frames_commands, 47);

}  // namespace

}  // namespace icube::tools
