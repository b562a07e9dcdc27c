// `icube nn vae` : InfiniCube's sparse structure VAE.
//
//   icube nn vae decode LATENT.npy --model CONFIG|infinicube-vae --weights VAE.safetensors
//                       [--latent-origin I,J,K] [--scale-factor S] [--backend gpu|cpu] [--precision fp32|fp16-weights|fp16]
//                       [--check-finite] [--scene SCENE [--mode M] --chunk K | --at X,Y,Z[,YAW_DEG]] [--dump-layers DIR] -o CHUNK.icw
//
// decode turns a dense latent [1, C, X, Y, Z] float32 (the box of latent
// voxels whose element [0,0,0] sits at --latent-origin, default the box
// centred on the origin as the official neck makes it) into the chunk's 0.2 m
// semantic voxels (engine/nn/vae_gpu.h, or the CPU reference with --backend
// cpu), written as an engine world (.icw) in the VAE's frame: voxel centres at
// ijk * 0.2 + 0.1 m (fVDB), each voxel the argmax of its 23 class logits
// (class 0, "undefined", is not written: the engine's 0 is empty); with a
// chunk placement (chunk K of a scene's plan, or --at) the chunk is moved into
// the world's frame by chunk fusion (world/chunk_fusion.h, conventions §9.4)
// on the world lattice (0.2 m, origin the chunk centre rounded to it). A latent
// from the diffusion model is divided by its scale_factor first (--scale-factor,
// else the weights' metadata as tools/convert_checkpoint.py writes it, else 1:
// nn/latent_scale.h). --dump-layers writes the files of models/vae_small: each
// level's grid before pruning and its structure logits (struct<d>.ijk.npy /
// .logits.npy, d = 0 finest), the final ijk.npy and semantic.npy, so a user can
// compare with PyTorch level by level (rows in brick order; compare as sets).
// --precision fp16-weights stores the convolution weights as fp16 (the GPU
// backend: tensor cores on NVIDIA GPUs; activations and sums stay fp32), fp16
// the GroupNorm outputs the convolutions read too (nn/network_precision.h).
// Outputs are written atomically; a failure leaves none.
//
//   icube nn vae encode WORLD.icw (--scene SCENE [--mode trajectory|blocks] --chunk K | --at X,Y,Z[,YAW_DEG])
//                       --model CONFIG|infinicube-vae --weights VAE.safetensors [--scale-factor S]
//                       [--backend gpu|cpu] [--precision fp32|fp16-weights|fp16] [--check-finite] -o LATENT.npy
//
// encode re-voxelises the world's voxels into one chunk's frame (engine/world/
// chunk_voxels.h: the chunk K of the scene's Stage-1 plan, or a chunk centred
// at X,Y,Z with its x axis at YAW_DEG from the world's), runs the VAE encoder
// and writes mu on the dense neck box as [1, C, X, Y, Z] float32 (box from
// -neck_bound, the layout decode reads), times the scale_factor (the diffusion
// model's latent space; resolved as for decode).
#include "cli_common.h"
#include "command_registry.h"
#include "staging_dir.h"

#include "diffusion/decoded_chunk.h"
#include "gpu/context.h"
#include "nn/latent_scale.h"
#include "nn/safetensors.h"
#include "nn/vae_config.h"
#include "nn/vae_gpu.h"
#include "nn/vae_reference.h"
#include "nn/vae_weights.h"
#include "scene/input_error.h"
#include "scene/scene_load.h"
#include "world/chunk_fusion.h"
#include "world/chunk_plan.h"
#include "world/chunk_voxels.h"
#include "world/npy.h"
#include "world/world_build.h"
#include "world/world_file.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>

namespace icube::tools {
namespace {

namespace fs = std::filesystem;

// Where a chunk sits in the world: chunk K of a scene's Stage-1 plan, or a pose given on the command line.
struct ChunkPlacement {
  std::string scene, mode = "trajectory", at;
  int chunk = -1;
  bool given() const { return !at.empty() || chunk >= 0 || !scene.empty(); }
};

struct VaeDecodeArgs {
  std::string latent, model, weights, origin, dump, output, backend = "gpu", precision = "fp32";
  ChunkPlacement place;
  double scale_factor = 1.0;
  bool scale_given = false;  // else from the weights' metadata, else 1
  bool check_finite = false;
};

world::ChunkPose parse_chunk_at(const std::string& text);

world::ChunkPose chunk_pose(const ChunkPlacement& p, scene::Diagnostics& diag) {
  const bool from_plan = p.chunk >= 0 || !p.scene.empty();
  if (!p.at.empty() ? from_plan : (p.chunk < 0 || p.scene.empty()))
    throw std::invalid_argument("give the chunk as --scene SCENE --chunk K, or as --at X,Y,Z[,YAW_DEG] (one of them)");
  if (!p.at.empty()) return parse_chunk_at(p.at);
  const scene::Scene s = scene::load_scene(p.scene, {}, &diag);
  const world::ChunkPlan plan = world::plan_chunks(s, p.mode == "blocks" ? world::PlanMode::Blocks : world::PlanMode::Trajectory);
  if (p.chunk >= static_cast<int>(plan.chunks.size()))
    throw scene::InputError(p.scene, "", "--chunk " + std::to_string(p.chunk) + ": the " + p.mode + " plan has " +
                                             std::to_string(plan.chunks.size()) + " chunks");
  return plan.chunks[static_cast<size_t>(p.chunk)];
}

void add_placement_options(CLI::App* cmd, ChunkPlacement& p, const std::string& verb) {
  cmd->add_option("--scene", p.scene, "Scene whose Stage-1 plan places the chunk (with --chunk)")->type_name("SCENE");
  cmd->add_option("--mode", p.mode, "Plan mode of --scene")->check(CLI::IsMember({"trajectory", "blocks"}))->capture_default_str();
  cmd->add_option("--chunk", p.chunk, "Chunk index in the plan")->type_name("K");
  cmd->add_option("--at", p.at, "Chunk centre in world metres and heading of its x axis (degrees, default 0)" + verb)
      ->type_name("X,Y,Z[,YAW_DEG]");
}

nn::Ijk parse_ijk(const std::string& text, const std::string& what) {
  nn::Ijk v{};
  std::istringstream in(text);
  char sep = 0;
  if (!(in >> v[0] >> sep) || sep != ',' || !(in >> v[1] >> sep) || sep != ',' || !(in >> v[2]) || !in.eof())
    throw std::invalid_argument(what + " '" + scene::printable(text) + "' is not I,J,K (three integers)");
  return v;
}

void write_levels(const fs::path& dir, const nn::VaeDecoded& d) {
  auto ijk_array = [](const nn::SparseGrid& g) {
    std::vector<int32_t> v;
    for (const nn::Ijk& c : g.ijk) v.insert(v.end(), c.begin(), c.end());
    return world::NpyArray::make<int32_t>({static_cast<uint64_t>(g.size()), 3}, v);
  };
  for (size_t depth = 0; depth < d.levels.size(); ++depth) {
    const std::string base = (dir / ("struct" + std::to_string(depth))).string();
    world::write_npy(base + ".ijk.npy", ijk_array(d.levels[depth].grid));
    world::write_npy(base + ".logits.npy",
                     world::NpyArray::make<float>({static_cast<uint64_t>(d.levels[depth].grid.size()), 2}, d.levels[depth].logits));
  }
  world::write_npy((dir / "ijk.npy").string(), ijk_array(d.semantic.grid));
  world::write_npy((dir / "semantic.npy").string(),
                   world::NpyArray::make<float>({static_cast<uint64_t>(d.semantic.rows()), static_cast<uint64_t>(d.semantic.channels)},
                                                d.semantic.data));
}

void cmd_vae_decode(const VaeDecodeArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    using Clock = std::chrono::steady_clock;
    const nn::VaeGpu::Precision precision = nn::parse_network_precision(a.precision, a.backend);
    const nn::VaeConfig cfg = nn::load_vae_config(a.model);
    const nn::SafetensorsFile file(a.weights);
    const nn::LatentScale scale = nn::resolve_latent_scale(a.scale_given ? std::optional<double>(a.scale_factor) : std::nullopt, file);
    std::optional<world::ChunkPose> pose;
    if (a.place.given()) pose = chunk_pose(a.place, diag);
    const world::NpyArray x = world::read_npy(a.latent);
    const uint64_t C = static_cast<uint64_t>(cfg.latent_channels());
    if (x.dtype != world::NpyDtype::F4 || x.shape.size() != 5 || x.shape[0] != 1 || x.shape[1] != C)
      throw scene::InputError(a.latent, "", "expected float32 [1, " + std::to_string(C) + ", X, Y, Z] (the model's latent)");
    const nn::Ijk dims{static_cast<int32_t>(x.shape[2]), static_cast<int32_t>(x.shape[3]), static_cast<int32_t>(x.shape[4])};
    if (uint64_t{x.shape[2]} * x.shape[3] * x.shape[4] > (uint64_t{1} << 24) || dims[0] > 4096 || dims[1] > 4096 || dims[2] > 4096)
      throw scene::InputError(a.latent, "", "a latent box of " + std::to_string(x.shape[2]) + " x " + std::to_string(x.shape[3]) +
                                                 " x " + std::to_string(x.shape[4]) + " voxels is too large (at most 2^24)");
    std::vector<float> v = x.values<float>();
    for (size_t i = 0; i < v.size(); ++i) {
      if (!std::isfinite(v[i])) throw scene::InputError(a.latent, "element " + std::to_string(i), "is not finite");
      v[i] = static_cast<float>(static_cast<double>(v[i]) / scale.value);
    }
    const nn::Ijk lo = a.origin.empty() ? nn::Ijk{-dims[0] / 2, -dims[1] / 2, -dims[2] / 2} : parse_ijk(a.origin, "--latent-origin");
    // The latent level's voxel: 0.2 m times the encoder's pooling factors.
    std::array<double, 3> vs{0.2, 0.2, 0.2}, origin{};
    for (int l = 1; l < cfg.num_blocks; ++l)
      for (int d = 0; d < 3; ++d) vs[d] *= cfg.pool_factor(l)[d];
    for (int d = 0; d < 3; ++d) origin[d] = vs[d] / 2.0;
    const nn::SparseGrid grid = nn::dense_box_grid(lo, dims, vs, origin);
    const nn::SparseTensor latent =
        nn::cpu::from_dense(nn::CpuTensor({1, static_cast<int64_t>(C), dims[0], dims[1], dims[2]}, v), lo, grid);

    nn::WeightOptions wo;
    wo.check_finite = a.check_finite;
    std::map<std::string, nn::CpuTensor> w = nn::load_vae_weights_cpu(file, cfg, nn::VaePart::Decoder, wo);
    std::optional<gpu::Context> ctx;
    std::fprintf(stderr, "vae decode: latent [1, %llu, %d, %d, %d] at ijk (%d, %d, %d) divided by scale_factor %g (%s), %s\n",
                 static_cast<unsigned long long>(C), dims[0], dims[1], dims[2], lo[0], lo[1], lo[2], scale.value,
                 scale.source.c_str(), a.backend == "gpu" ? "GPU" : "CPU reference");
    const Clock::time_point t0 = Clock::now();
    nn::VaeDecoded d;
    uint64_t activation_bytes = 0, weight_bytes = 0;
    if (a.backend == "gpu") {
      ctx.emplace(gpu::ContextOptions::from_env());
      nn::VaeGpu vae(*ctx, cfg, w, precision);
      d = vae.decode(latent);
      activation_bytes = vae.last_activation_bytes();
      weight_bytes = vae.weight_bytes();
      for (const nn::VaeGpu::Stage& st : vae.last_stages())
        std::fprintf(stderr, "vae decode: %-48s %9u rows %10.1f ms\n", st.label.c_str(), st.rows, st.ms);
    } else {
      d = nn::VaeReference(cfg, std::move(w)).decode(latent);
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    if (!d.warning.empty()) diag.warn(a.latent, "", d.warning);

    // The chunk as an engine world. In the VAE's frame: engine centres (ijk + 0.5) * vs + origin = fVDB's
    // ijk * vs + fVDB origin. Placed (--at / --scene --chunk): moved into the world by chunk fusion
    // (conventions §9.4: exact copy on a shifted lattice, else subdivided and re-voxelised).
    // Unplaced, the world's lattice is the chunk's own, so the fusion copies the cells exactly.
    const nn::SparseGrid& g = d.semantic.grid;
    uint64_t undefined = 0;
    const world::ChunkVoxels chunk = diffusion::decoded_chunk(d, pose ? pose->chunk_to_world : glm::dmat4(1.0), &undefined);
    world::VoxelGrid out(pose ? world::world_lattice_origin(*pose) : glm::dvec3(chunk.lattice_to_world[3]), g.voxel_size[0]);
    const world::FusionStats placed = world::fuse_chunk(out, chunk);
    std::optional<StagingDir> staging;
    if (!a.dump.empty()) {
      const fs::path dump(a.dump);
      staging.emplace(dump.parent_path().empty() ? fs::path(".") : dump.parent_path(), dump.filename().string());
      write_levels(staging->path, d);
    }
    world::save_world(out, a.output);
    if (staging) {
      fs::remove_all(a.dump);
      fs::rename(staging->path, a.dump);
      staging->keep = true;
    }
    std::printf("vae decode: %lld voxels at %.2f m (%llu of class 0 'undefined' left out) in %.2f s", static_cast<long long>(g.size()),
                g.voxel_size[0], static_cast<unsigned long long>(undefined), seconds);
    if (pose)
      std::printf("; placed at (%.2f, %.2f, %.2f): %llu world cells (%s)", pose->chunk_to_world[3][0], pose->chunk_to_world[3][1],
                  pose->chunk_to_world[3][2], static_cast<unsigned long long>(placed.written),
                  placed.exact_copy ? "the world lattice, copied exactly" : "re-voxelised");
    for (size_t depth = d.levels.size(); depth-- > 0;)
      std::printf("%s depth %zu: %lld", depth + 1 == d.levels.size() ? ";" : ",", depth, static_cast<long long>(d.levels[depth].grid.size()));
    std::printf("\n");
    if (a.backend == "gpu")
      std::printf("vae decode: %.1f MiB of activations (peak pool) and %.1f MiB of weights on the device\n",
                  static_cast<double>(activation_bytes) / (1024.0 * 1024.0), static_cast<double>(weight_bytes) / (1024.0 * 1024.0));
    std::printf("vae decode: wrote %s%s\n", a.output.c_str(), a.dump.empty() ? "" : (" and " + a.dump + "/").c_str());
  });
}

struct VaeEncodeArgs {
  std::string world, model, weights, output, backend = "gpu", precision = "fp32";
  ChunkPlacement place;
  double scale_factor = 1.0;
  bool scale_given = false;  // else from the weights' metadata, else 1
  bool check_finite = false;
};

world::ChunkPose parse_chunk_at(const std::string& text) {
  std::vector<double> v;
  std::istringstream in(text);
  std::string part;
  while (std::getline(in, part, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stod(part, &used));
      if (used != part.size()) v.clear(), v.resize(9);
    } catch (const std::exception&) {
      v.resize(9);
    }
  }
  if ((v.size() != 3 && v.size() != 4) || !std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]) ||
      (v.size() == 4 && !std::isfinite(v[3])))
    throw std::invalid_argument("--at '" + scene::printable(text) + "' is not X,Y,Z or X,Y,Z,YAW_DEG");
  const double yaw = v.size() == 4 ? v[3] * 3.14159265358979323846 / 180.0 : 0.0;
  world::ChunkPose pose;
  pose.chunk_to_world = glm::dmat4(glm::dvec4(std::cos(yaw), std::sin(yaw), 0, 0), glm::dvec4(-std::sin(yaw), std::cos(yaw), 0, 0),
                                   glm::dvec4(0, 0, 1, 0), glm::dvec4(v[0], v[1], v[2], 1));
  return pose;
}

void cmd_vae_encode(const VaeEncodeArgs& a) {
  run_command([&](scene::Diagnostics& diag) {
    using Clock = std::chrono::steady_clock;
    const nn::VaeGpu::Precision precision = nn::parse_network_precision(a.precision, a.backend);
    refuse_overwriting_input(a.world, a.output);
    const nn::VaeConfig cfg = nn::load_vae_config(a.model);
    const world::ChunkPose pose = chunk_pose(a.place, diag);
    const world::VoxelGrid w = world::load_world(a.world);
    const world::ChunkVoxelList voxels = world::chunk_voxels(w, pose);
    if (voxels.ijk.empty())
      throw scene::InputError(a.world, "", "the chunk at (" + std::to_string(pose.chunk_to_world[3][0]) + ", " +
                                               std::to_string(pose.chunk_to_world[3][1]) + ", " +
                                               std::to_string(pose.chunk_to_world[3][2]) + ") holds no voxel of the world");
    nn::SparseGrid fine;
    fine.voxel_size = {world::kFineVoxel, world::kFineVoxel, world::kFineVoxel};
    fine.origin = {world::kFineVoxel / 2, world::kFineVoxel / 2, world::kFineVoxel / 2};
    fine.ijk = voxels.ijk;
    const std::vector<int32_t> classes(voxels.class_id.begin(), voxels.class_id.end());
    nn::WeightOptions wo;
    wo.check_finite = a.check_finite;
    const nn::SafetensorsFile file(a.weights);
    const nn::LatentScale scale = nn::resolve_latent_scale(a.scale_given ? std::optional<double>(a.scale_factor) : std::nullopt, file);
    std::map<std::string, nn::CpuTensor> wts = nn::load_vae_weights_cpu(file, cfg, nn::VaePart::Encoder, wo);
    std::fprintf(stderr, "vae encode: %zu voxels of %s in the chunk, %s\n", voxels.ijk.size(), a.world.c_str(),
                 a.backend == "gpu" ? "GPU" : "CPU reference");
    const Clock::time_point t0 = Clock::now();
    nn::SparseTensor mu;
    uint64_t activation_bytes = 0;
    std::optional<gpu::Context> ctx;
    if (a.backend == "gpu") {
      ctx.emplace(gpu::ContextOptions::from_env());
      nn::VaeGpu vae(*ctx, cfg, wts, precision);
      mu = vae.encode(fine, classes);
      activation_bytes = vae.last_activation_bytes();
      for (const nn::VaeGpu::Stage& st : vae.last_stages())
        std::fprintf(stderr, "vae encode: %-48s %9u rows %10.1f ms\n", st.label.c_str(), st.rows, st.ms);
    } else {
      mu = nn::VaeReference(cfg, std::move(wts)).encode(fine, classes);
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    // Dense [1, C, X, Y, Z] over the neck box (or the latent grid's bounding box without a dense neck).
    nn::Ijk lo = mu.grid.ijk.front(), hi = lo;
    for (const nn::Ijk& c : mu.grid.ijk)
      for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], c[d]), hi[d] = std::max(hi[d], c[d]);
    const nn::Ijk dims{hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1};
    nn::CpuTensor dense = nn::cpu::to_dense(mu, lo, dims);
    for (float& v : dense.data) v = static_cast<float>(static_cast<double>(v) * scale.value);
    world::write_npy(a.output, world::NpyArray::make<float>({1, static_cast<uint64_t>(mu.channels), static_cast<uint64_t>(dims[0]),
                                                             static_cast<uint64_t>(dims[1]), static_cast<uint64_t>(dims[2])},
                                                            dense.data));
    std::printf("vae encode: latent [1, %lld, %d, %d, %d] from ijk (%d, %d, %d), times scale_factor %g (%s), in %.2f s",
                static_cast<long long>(mu.channels), dims[0], dims[1], dims[2], lo[0], lo[1], lo[2], scale.value, scale.source.c_str(),
                seconds);
    if (a.backend == "gpu") std::printf(", %.1f MiB of activations (peak pool)", static_cast<double>(activation_bytes) / (1024.0 * 1024.0));
    std::printf("\nvae encode: wrote %s\n", a.output.c_str());
  });
}

void add_vae_commands(CLI::App& app) {
  CLI::App& nn_group = subcommand_group(app, "nn", "Networks: weight files (safetensors), the diffusion UNet");
  CLI::App* vae = nn_group.add_subcommand("vae", "InfiniCube's sparse structure VAE");
  vae->require_subcommand(1);
  auto a = std::make_shared<VaeDecodeArgs>();
  CLI::App* dec = vae->add_subcommand("decode", "Decode a dense latent into a chunk's 0.2 m semantic voxels (.icw)");
  dec->add_option("latent", a->latent, "Latent: float32 [1, C, X, Y, Z]")->required()->type_name("LATENT.npy");
  dec->add_option("--model", a->model, "VAE config JSON (official StructPredictionNet kwargs) or preset infinicube-vae")
      ->required()
      ->type_name("CONFIG");
  dec->add_option("--weights", a->weights, "Weights (.safetensors; unet.* / encoder.* names, or under vae.)")
      ->required()
      ->type_name("W");
  dec->add_option("--latent-origin", a->origin, "Latent ijk of element [0,0,0] (default: the box centred on 0)")->type_name("I,J,K");
  dec->add_option("--scale-factor", a->scale_factor,
                  "Divide the latent by this first (default: the weights' metadata scale_factor, else 1)")
      ->type_name("S")
      ->each([a](const std::string&) { a->scale_given = true; });
  dec->add_option("--backend", a->backend, "gpu (Vulkan kernels) or cpu (the exact double-accumulation reference)")
      ->check(CLI::IsMember({"gpu", "cpu"}))
      ->capture_default_str();
  dec->add_option("--precision", a->precision,
                  std::string("GPU backend: ") + nn::network_precision_help())
      ->check(CLI::IsMember({"fp32", "fp16-weights", "fp16"}))
      ->capture_default_str();
  dec->add_flag("--check-finite", a->check_finite, "Fail on a NaN or infinity in the weights");
  add_placement_options(dec, a->place, ": the chunk is written in the world's frame");
  dec->add_option("--dump-layers", a->dump, "Write each level's grid, structure logits and the final class logits here (.npy)")
      ->type_name("DIR");
  dec->add_option("-o,--output", a->output, "The decoded chunk (.icw)")->required()->type_name("CHUNK.icw");
  dec->callback([a] { cmd_vae_decode(*a); });

  auto e = std::make_shared<VaeEncodeArgs>();
  CLI::App* enc = vae->add_subcommand("encode", "Encode one chunk of a world (.icw) into the VAE's dense latent (.npy)");
  enc->add_option("world", e->world, "World (.icw)")->required()->type_name("WORLD.icw");
  add_placement_options(enc, e->place, "");
  enc->add_option("--model", e->model, "VAE config JSON (official StructPredictionNet kwargs) or preset infinicube-vae")
      ->required()
      ->type_name("CONFIG");
  enc->add_option("--weights", e->weights, "Weights (.safetensors; encoder.* and unet.* names, or under vae.)")
      ->required()
      ->type_name("W");
  enc->add_option("--scale-factor", e->scale_factor,
                  "Multiply the latent by this (default: the weights' metadata scale_factor, else 1)")
      ->type_name("S")
      ->each([e](const std::string&) { e->scale_given = true; });
  enc->add_option("--backend", e->backend, "gpu (Vulkan kernels) or cpu (the exact double-accumulation reference)")
      ->check(CLI::IsMember({"gpu", "cpu"}))
      ->capture_default_str();
  enc->add_option("--precision", e->precision,
                  std::string("GPU backend: ") + nn::network_precision_help())
      ->check(CLI::IsMember({"fp32", "fp16-weights", "fp16"}))
      ->capture_default_str();
  enc->add_flag("--check-finite", e->check_finite, "Fail on a NaN or infinity in the weights");
  enc->add_option("-o,--output", e->output, "mu on the dense neck box: float32 [1, C, X, Y, Z]")->required()->type_name("LATENT.npy");
  enc->callback([e] { cmd_vae_encode(*e); });
}

const CommandRegistrar kNnVaeRegistrar(add_vae_commands, 51);

}  // namespace
}  // namespace icube::tools
