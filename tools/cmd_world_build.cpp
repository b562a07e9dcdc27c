// `icube world build` (Stage 1: a semantic voxel world from a scene, chunk by
// chunk, engine/world/world_build.h) and `icube world plot` (a top-down PNG
// of a world, engine/world/world_plot.h).
//
//   icube world build SCENE -o world.icw [--mode trajectory|blocks] [--generator procedural|diffusion]
//                     [--seed N] [--record SEL] [--extrapolate N] [--max-chunks N] [--threads N] [--no-vehicles]
//                     [--vehicle-mesh FILE [--mesh-axes F,U] | --vehicle-meshes JSON] [--png top.png]
//     diffusion:      --model CONFIG|PRESET --weights UNET.safetensors --vae VAE.safetensors [--vae-model CONFIG|PRESET]
//                     [--steps N] [--sampler ddim|dpm++2m] [--eta E] [--cfg S] [--precision fp32|fp16-weights|fp16] [--scale-factor S] [--keep-latents DIR]
//   icube world plot WORLD -o top.png [--max-pixels N]
#include "cli_common.h"
#include "command_registry.h"
#include "mesh_args.h"
#include "progress.h"
#include "world_top_png.h"

#include "diffusion/diffusion_generator.h"
#include "gpu/context.h"
#include "nn/latent_scale.h"
#include "nn/safetensors.h"
#include "nn/unet_reference.h"
#include "nn/vae_weights.h"
#include "nn/weights.h"
#include "scene/scene_load.h"
#include "world/procedural/procedural_prior.h"
#include "world/semantics.h"
#include "world/vehicle_mesh_set.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <sys/resource.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace icube::tools {

namespace {

struct BuildArgs {
  std::string file, output, record, png, vehicle_mesh, vehicle_meshes, mesh_axes = "auto";
  std::string mode = "trajectory";
  std::string generator = "procedural";
  uint64_t seed = 0;
  int threads = 0;
  bool no_vehicles = false;
  world::PlanOptions plan;
  // --generator diffusion
  std::string model, weights, vae, vae_model, precision = "fp32", keep_latents;
  int steps = 100;
  std::string sampler = "ddim";
  float eta = 1.0f, cfg = 2.0f;
  bool eta_given = false;
  double scale_factor = 1.0;
  bool scale_given = false;
};

double peak_rss_mib() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_maxrss) / 1024.0;  // Linux: KiB
}

void print_summary(const world::WorldBuildResult& r, const world::WorldGenerator& gen,
                   const world::VehicleMeshSet& meshes) {
  const world::VoxelGrid& g = r.world;
  const double voxels = static_cast<double>(g.voxel_count());
  std::printf("built %s world (%s generator): %zu chunk(s), %llu voxels in %zu bricks, %.1f MiB\n",
              world::plan_mode_name(r.plan.mode), gen.name().c_str(), r.plan.chunks.size(),
              static_cast<unsigned long long>(g.voxel_count()), g.brick_count(),
              static_cast<double>(g.memory_bytes()) / (1024.0 * 1024.0));
  std::printf("  time %.2f s (plan %.2f, generate %.2f cpu-s, fuse %.2f, vehicles %.2f): %.1f chunks/s, %.2f Mvoxels/s; "
              "peak RSS %.0f MiB\n",
              r.total_s, r.plan_s, r.generate_s, r.fuse_s, r.vehicles_s,
              r.total_s > 0 ? static_cast<double>(r.plan.chunks.size()) / r.total_s : 0.0,
              r.total_s > 0 ? voxels / r.total_s * 1e-6 : 0.0, peak_rss_mib());
  std::printf("  %zu static vehicle(s) inserted, %llu voxels", r.vehicles_inserted,
              static_cast<unsigned long long>(r.vehicle_voxels));
  for (size_t i = 0; i < r.vehicles_per_type.size() && i < meshes.types.size(); ++i)
    std::printf("%s %zu %s (%s)", i ? "," : ":", r.vehicles_per_type[i], meshes.types[i].name.c_str(),
                meshes.types[i].source.c_str());
  std::printf("\n");
  const auto hist = g.class_histogram();
  std::printf("  classes:");
  int shown = 0;
  for (int c = 1; c < world::kNumSemanticClasses; ++c) {
    const uint64_t n = hist[static_cast<size_t>(c)];
    if (!n) continue;
    std::printf("%s %s %.2f%%", shown++ % 6 == 0 ? "\n   " : ",", world::semantic_class_name(static_cast<uint8_t>(c)),
                voxels > 0 ? 100.0 * static_cast<double>(n) / voxels : 0.0);
  }
  std::printf("\n");
}

// --vehicle-mesh, --vehicle-meshes or the built-in car; read before any chunk is built.
world::VehicleMeshSet vehicle_meshes(const BuildArgs& a) {
  const auto axes = mesh_axes_arg(a.mesh_axes);
  if (!a.vehicle_meshes.empty()) return world::load_vehicle_mesh_set(a.vehicle_meshes);
  if (a.vehicle_mesh.empty()) return world::builtin_vehicle_meshes();
  world::VehicleMeshFile f = world::load_vehicle_mesh(a.vehicle_mesh, axes);
  const std::string source = describe_mesh(a.vehicle_mesh, f);
  return world::single_vehicle_mesh(std::move(f), source);
}

// The learned generator: configurations and weights loaded and checked before any chunk runs.
std::unique_ptr<diffusion::DiffusionGenerator> make_diffusion_generator(const BuildArgs& a, const scene::Scene& s,
                                                                        world::PlanMode mode, std::optional<gpu::Context>& ctx,
                                                                        scene::Diagnostics& diag,
                                                                        std::optional<ProgressBar>& bar) {
  if (a.model.empty() || a.weights.empty() || a.vae.empty())
    throw std::invalid_argument("--generator diffusion needs --model, --weights (the UNet) and --vae (the structure VAE)");
  if (!a.keep_latents.empty()) refuse_overwriting_input(a.file, a.keep_latents);
  const nn::UNetConfig unet_cfg = nn::load_unet_config(a.model);
  // The VAE's configuration: --vae-model, else vae_config.json beside the VAE weights (the converter writes
  // it there), else the released preset.
  std::string vae_model = a.vae_model;
  if (vae_model.empty()) {
    const std::filesystem::path beside = std::filesystem::path(a.vae).parent_path() / "vae_config.json";
    vae_model = std::filesystem::exists(beside) ? beside.string() : "infinicube-vae";
  }
  const nn::VaeConfig vae_cfg = nn::load_vae_config(vae_model);
  const nn::SafetensorsFile unet_file(a.weights), vae_file(a.vae);
  const std::map<std::string, nn::CpuTensor> unet_w =
      nn::load_weights_cpu(unet_file, nn::UNetReference(unet_cfg).parameters(), nn::WeightOptions{});
  const std::map<std::string, nn::CpuTensor> vae_w = nn::load_vae_weights_cpu(vae_file, vae_cfg, nn::VaePart::Decoder, {});
  nn::LatentScale scale = nn::resolve_latent_scale(a.scale_given ? std::optional<double>(a.scale_factor) : std::nullopt, unet_file);
  if (!scale.given()) scale = nn::resolve_latent_scale(std::nullopt, vae_file);
  if (!scale.given())
    diag.warn(a.weights, "__metadata__", "no scale_factor (neither --scale-factor nor the weights' metadata): using 1");

  diffusion::DiffusionGeneratorOptions o;
  o.sampler.ddim.steps = a.steps;
  o.sampler.kind = a.sampler == "dpm++2m" ? diffusion::SamplerKind::kDpmSolver2M : diffusion::SamplerKind::kDdim;
  // DPM-Solver++ is deterministic: eta defaults to 0 there, and a given eta != 0 is refused.
  o.sampler.ddim.eta = o.sampler.kind == diffusion::SamplerKind::kDpmSolver2M && !a.eta_given ? 0.0f : a.eta;
  o.sampler.cfg_scale = a.cfg;
  o.sampler.seed = a.seed;
  o.scale_factor = scale.value;
  o.precision = nn::parse_network_precision(a.precision);
  o.keep_latents = a.keep_latents;
  // One bar per chunk over its denoising steps (elapsed time and ETA).
  o.progress = [&bar, current = std::make_shared<size_t>(SIZE_MAX)](size_t chunk, size_t done, size_t total) {
    if (*current != chunk) {
      *current = chunk;
      bar.emplace("world build: chunk " + std::to_string(chunk), "sampling steps");
    }
    bar->update(done, total);
  };
  ctx.emplace(gpu::ContextOptions::from_env());
  std::fprintf(stderr,
               "world build: diffusion UNet %s (%s), VAE %s (%s), %d %s steps, eta %g, cfg %g, scale_factor %g (%s), "
               "precision %s\n",
               a.weights.c_str(), a.model.c_str(), a.vae.c_str(), vae_model.c_str(), a.steps,
               diffusion::sampler_kind_name(o.sampler.kind), static_cast<double>(o.sampler.ddim.eta),
               static_cast<double>(a.cfg), scale.value, scale.source.c_str(), nn::network_precision_name(o.precision));
  return std::make_unique<diffusion::DiffusionGenerator>(*ctx, s, mode, unet_cfg, unet_w, vae_cfg, vae_w, o);
}

void print_diffusion_summary(const diffusion::DiffusionGenerator& g, const std::string& file, scene::Diagnostics& diag) {
  double cond = 0, sample = 0, decode = 0;
  for (size_t n = 0; n < g.timings().size(); ++n) {
    const diffusion::ChunkTiming& t = g.timings()[n];
    cond += t.conditions_ms;
    sample += t.sample_ms;
    decode += t.decode_ms;
    std::printf("  chunk %zu: conditions %.0f ms, sampling %.1f s (%llu known latent cells), decode %.1f s, %llu voxels\n", n,
                t.conditions_ms, t.sample_ms / 1000.0, static_cast<unsigned long long>(t.known_cells), t.decode_ms / 1000.0,
                static_cast<unsigned long long>(t.voxels));
    if (!t.warning.empty()) diag.warn(file, "chunk " + std::to_string(n), t.warning);
  }
  std::printf("  diffusion: conditions %.2f s, sampling %.1f s, VAE decode %.1f s over %zu chunk(s); device memory peak ~%.0f MiB "
              "(weights + largest activation pool)\n",
              cond / 1000.0, sample / 1000.0, decode / 1000.0, g.timings().size(),
              static_cast<double>(g.peak_device_bytes()) / (1024.0 * 1024.0));
}

void cmd_build(BuildArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    refuse_overwriting_input(a.file, a.output);
    if (!a.png.empty()) refuse_overwriting_input(a.file, a.png);
    scene::LoadOptions lo;
    lo.waymo_selector = a.record;
    const scene::Scene s = scene::load_scene(a.file, lo, &diag);
    const world::VehicleMeshSet meshes = vehicle_meshes(a);
    const world::PlanMode mode = a.mode == "blocks" ? world::PlanMode::Blocks : world::PlanMode::Trajectory;
    std::optional<gpu::Context> ctx;
    std::unique_ptr<world::WorldGenerator> generator;
    diffusion::DiffusionGenerator* learned = nullptr;
    std::optional<ProgressBar> step_bar;
    if (a.generator == "diffusion") {
      auto g = make_diffusion_generator(a, s, mode, ctx, diag, step_bar);
      learned = g.get();
      generator = std::move(g);
    } else {
      generator = std::make_unique<world::ProceduralPrior>(s);
    }

    world::WorldBuildOptions opts;
    opts.mode = mode;
    opts.plan = a.plan;
    opts.seed = a.seed;
    opts.threads = a.threads;
    opts.insert_static_vehicles = !a.no_vehicles;
    opts.vehicle_meshes = &meshes;
    ProgressBar bar("world build", "chunks");
    if (!learned) opts.progress = [&](size_t done, size_t total) { bar.update(done, total); };
    const world::WorldBuildResult r = world::build_world(s, *generator, opts);
    for (const std::string& note : r.plan.notes) diag.warn(a.file, "plan", note);
    world::save_world(r.world, a.output);
    print_summary(r, *generator, meshes);
    if (learned) print_diffusion_summary(*learned, a.file, diag);
    std::printf("wrote %s\n", a.output.c_str());
    if (!a.png.empty()) write_top_png(r.world, a.png);
  });
}

void cmd_plot(const std::string& input, const std::string& output, int max_pixels) {
  run_command([&](scene::Diagnostics&) {
    refuse_overwriting_input(input, output);
    const world::VoxelGrid g = world::load_world(input);
    write_top_png(g, output, max_pixels);
  });
}

void add_world_build_commands(CLI::App& app) {
  CLI::App& world_cmd = subcommand_group(app, "world", "Build, inspect, import and export semantic voxel worlds");

  auto a = std::make_shared<BuildArgs>();
  CLI::App* build = world_cmd.add_subcommand(
      "build", "Stage 1: generate a semantic voxel world (0.2 m, 23 classes) for a scene, chunk by chunk, and save it");
  build->add_option("file", a->file, "Scene file: icube scene JSON, Waymo Scenario TFRecord, or OpenDRIVE .xodr")
      ->required()
      ->type_name("SCENE");
  build->add_option("-o,--output", a->output, "Output world file")->required()->type_name("world.icw");
  build->add_option("--record", a->record, "Waymo TFRecord only: which record, by index or scenario id")
      ->type_name("SEL");
  build->add_option("--mode", a->mode, "trajectory: chunks along the ego drive; blocks: world-axis lattice over the road")
      ->check(CLI::IsMember({"trajectory", "blocks"}))
      ->type_name("MODE")
      ->capture_default_str();
  build->add_option("--generator", a->generator,
                    "procedural: the built-in procedural world prior (rules on the map, not a learned model); "
                    "diffusion: InfiniCube's map-conditioned latent diffusion UNet + structure VAE (--model, --weights, --vae)")
      ->check(CLI::IsMember({"procedural", "diffusion"}))
      ->type_name("NAME")
      ->capture_default_str();
  build->add_option("--seed", a->seed, "Generator seed (same seed, same scene: identical world file)")
      ->type_name("N")
      ->capture_default_str();
  build->add_option("--max-chunks", a->plan.max_chunks,
                    "Build only the plan's first N chunks (0 = all): try a model or its settings on a chunk or two first")
      ->type_name("N")
      ->check(CLI::Range(0, 1000000))
      ->capture_default_str();
  build->add_option("--extrapolate", a->plan.extrapolate_chunks,
                    "Trajectory mode: chunks to continue straight past the end of the drive")
      ->type_name("N")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  build->add_option("--threads", a->threads, "Generator threads (0: one per core); the result does not depend on it")
      ->type_name("N")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  build->add_flag("--no-vehicles", a->no_vehicles, "Do not insert the static vehicles of the first frame");
  CLI::Option* mesh_opt =
      build->add_option("--vehicle-mesh", a->vehicle_mesh,
                        "Voxelise every static vehicle from this mesh (PLY, OBJ, glTF/GLB) instead of the built-in car")
          ->type_name("FILE");
  build->add_option("--vehicle-meshes", a->vehicle_meshes,
                    "Per-type meshes picked by box length, e.g. {\"car\": {\"mesh\": \"car.ply\", \"length\": [0, 6.5]}, "
                    "\"truck\": {\"mesh\": \"truck.glb\", \"length\": [6.5, 10]}} (docs/vehicle-meshes.md)")
      ->type_name("JSON")
      ->excludes(mesh_opt);
  build->add_option("--mesh-axes", a->mesh_axes, std::string(kMeshAxesHelp) + " (for --vehicle-mesh)")
      ->type_name("FORWARD,UP")
      ->needs(mesh_opt)
      ->capture_default_str();
  build->add_option("--png", a->png, "Also write a top-down picture of the world")->type_name("top.png");
  build->add_option("--model", a->model, "diffusion: UNet config JSON (official UNetModel kwargs, e.g. the converter's "
                                         "unet_config.json) or preset infinicube-diffusion")
      ->type_name("CONFIG");
  build->add_option("--weights", a->weights, "diffusion: UNet weights (.safetensors, official names)")->type_name("UNET.safetensors");
  build->add_option("--vae", a->vae, "diffusion: structure VAE weights (.safetensors)")->type_name("VAE.safetensors");
  build->add_option("--vae-model", a->vae_model,
                    "diffusion: VAE config or preset (default: vae_config.json beside --vae, else infinicube-vae)")
      ->type_name("CONFIG");
  build->add_option("--steps", a->steps, "diffusion: sampling steps")->check(CLI::Range(1, 1000))->capture_default_str();
  build->add_option("--sampler", a->sampler,
                    "diffusion: ddim (the official sampler) or dpm++2m (DPM-Solver++ 2M, deterministic; "
                    "bench/README.md gives the steps at which it matches DDIM's error)")
      ->check(CLI::IsMember({"ddim", "dpm++2m"}))
      ->capture_default_str();
  build->add_option("--eta", a->eta, "diffusion: DDIM eta (1: the official stochastic sampler, 0: deterministic)")
      ->check(CLI::Range(0.0, 10.0))
      ->each([a](const std::string&) { a->eta_given = true; })
      ->capture_default_str();
  build->add_option("--cfg", a->cfg, "diffusion: guidance scale s, v = cond + s (cond - uncond); 1 = one pass (the official "
                                     "CLI's default), 2 = the official full pipeline's")
      ->capture_default_str();
  build->add_option("--precision", a->precision,
                    std::string("diffusion, the UNet and the VAE: ") + nn::network_precision_help())
      ->check(CLI::IsMember({"fp32", "fp16-weights", "fp16"}))
      ->capture_default_str();
  build->add_option("--scale-factor", a->scale_factor,
                    "diffusion: latent scale factor (default: the weights' metadata, else 1 with a warning)")
      ->type_name("S")
      ->each([a](const std::string&) { a->scale_given = true; });
  build->add_option("--keep-latents", a->keep_latents, "diffusion: write each chunk's final latent here (chunk_NNNN.npy)")
      ->type_name("DIR");
  build->footer(
      "Chunks are fused in plan order with existing voxels winning. Static vehicles (the boxes of frame 0 that "
      "never move) are voxelised into the chunks they stand in from the built-in car mesh, --vehicle-mesh or the "
      "type --vehicle-meshes picks by box length (whose name is also the voxels' class).");
  build->callback([a] { cmd_build(*a); });

  auto in = std::make_shared<std::string>(), out = std::make_shared<std::string>();
  auto max_px = std::make_shared<int>(4096);
  CLI::App* plot = world_cmd.add_subcommand(
      "plot", "Write a top-down PNG of a world: each column's highest voxel, coloured by class, shaded by height");
  plot->add_option("world", *in, "World file (.icw)")->required()->type_name("WORLD");
  plot->add_option("-o,--output", *out, "Output PNG")->required()->type_name("top.png");
  plot->add_option("--max-pixels", *max_px, "Longest side of the picture; larger worlds are drawn coarser")
      ->check(CLI::Range(64, 16384))
      ->capture_default_str();
  plot->callback([in, out, max_px] { cmd_plot(*in, *out, *max_px); });
}

const CommandRegistrar kWorldBuildRegistrar(add_world_build_commands, 32);

}  // namespace

}  // namespace icube::tools
