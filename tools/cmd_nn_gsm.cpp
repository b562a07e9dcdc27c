// `icube nn gsm` : InfiniCube's stage-3 feed-forward reconstruction model (GSM).
//
//   icube nn gsm forward --model CONFIG --weights W.safetensors --inputs DIR [--backend gpu|cpu]
//                        [--dump-layers FILE.safetensors] -o OUT.safetensors
//
// forward runs the model on a case folder laid out as models/gsm_small/inputs
// (images.npy, masks.npy, poses.npy, intrinsics.npy, voxel_ijk.b<i>.npy,
// depth_patch_keep.npy: engine/nn/gsm/gsm_inputs.h) and writes the outputs under
// the reference case's names (gs.b<i>.voxel.*, gs.b<i>.pixel.*, sky.tokens,
// sky.image, sky.panorama; index tensors I32). --dump-layers writes every
// intermediate under the names of the case's intermediates.safetensors (all
// float32; integer tensors as exact floats), so a user can find the first stage
// that differs from PyTorch. CONFIG is a case's config.json (tools/
// convert_checkpoint.py writes gsm_config.json in that form) or the preset
// infinicube-gsm (the released model). The weights are checked against the
// configuration's state dict (every tensor, shape, dtype; finite) before any
// work. The forward runs on the GPU (engine/nn/gsm/gsm_gpu.h: the network
// stages, the sky token, the sky colours and the pixel rays on the device; the sky token's patch
// gather and the rays near a tie on the host)
// or, with --backend cpu, on the plain CPU reference (gsm_reference.h); both
// equal the official model within 1e-4 of each tensor's std. Per-stage times
// are printed. Outputs are written atomically and only after the whole forward
// succeeded.
#include "cli_common.h"
#include "command_registry.h"

#include "gpu/context.h"
#include "nn/gsm/gsm_gpu.h"
#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_reference.h"
#include "nn/safetensors.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

namespace icube::tools {
namespace {

struct GsmForwardArgs {
  std::string model, weights, inputs, dump, output, backend = "gpu";
};

void cmd_gsm_forward(const GsmForwardArgs& a) {
  run_command([&](scene::Diagnostics&) {
    for (const std::string& input : {a.model, a.weights}) {
      refuse_overwriting_input(input, a.output);
      if (!a.dump.empty()) refuse_overwriting_input(input, a.dump);
    }
    if (a.dump == a.output) throw std::invalid_argument("--dump-layers and -o name the same file");
    using Clock = std::chrono::steady_clock;
    const Clock::time_point t0 = Clock::now();
    const nn::GsmModelConfig model = nn::load_gsm_model_config(a.model);
    const nn::GsmConfig& config = model.config;
    const nn::GsmInputs in = nn::read_gsm_inputs(a.inputs);
    nn::check_gsm_inputs(config, in, a.inputs);
    // Every tensor checked against the configuration's state dict (names, shapes, dtypes) and finite,
    // before any work.
    const nn::GsmWeights weights = nn::load_gsm_weights(a.weights, model, true);
    size_t voxels = 0;
    for (const auto& v : in.voxel_ijk) voxels += v.size();
    std::fprintf(stderr, "gsm forward: %lld x %lld views of %lld x %lld, %zu voxels, %zu weight tensors (%s)\n",
                 static_cast<long long>(in.batch), static_cast<long long>(in.views), static_cast<long long>(in.height),
                 static_cast<long long>(in.width), voxels, weights.tensors.size(),
                 a.backend == "gpu" ? "GPU" : "CPU reference");
    nn::GsmTrace trace;
    nn::GsmTrace* tp = a.dump.empty() ? nullptr : &trace;
    nn::GsmOutputs out;
    if (a.backend == "gpu") {
      gpu::Context ctx(gpu::ContextOptions::from_env());
      nn::GsmGpu gsm(ctx, config, weights);
      out = gsm.forward(in, tp);
      for (const nn::GsmGpu::Stage& st : gsm.last_stages())
        std::fprintf(stderr, "gsm forward: %-52s %9.1f ms%s\n", st.label.c_str(), st.ms, st.on_device ? "" : " (host)");
      std::fprintf(stderr, "gsm forward: %.1f MiB of weights, %.1f MiB of activations (peak pool) on %s\n",
                   static_cast<double>(gsm.weight_bytes()) / 1048576.0, static_cast<double>(gsm.last_activation_bytes()) / 1048576.0,
                   ctx.info().name.c_str());
    } else {
      out = nn::gsm_forward_reference(config, weights, in, tp);
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    if (!a.dump.empty()) nn::write_safetensors(a.dump, nn::gsm_trace_tensors(trace), {{"source", "icube nn gsm forward"}});
    nn::write_safetensors(a.output, nn::gsm_output_tensors(out), {{"source", "icube nn gsm forward"}});
    for (size_t b = 0; b < out.elements.size(); ++b)
      std::printf("gsm forward: batch element %zu: %lld voxel and %lld pixel Gaussians\n", b,
                  static_cast<long long>(out.elements[b].voxel.count()), static_cast<long long>(out.elements[b].pixel.count()));
    std::printf("gsm forward: %.2f s; wrote %s%s%s\n", seconds, a.output.c_str(), a.dump.empty() ? "" : " and ",
                a.dump.c_str());
  });
}

void add_gsm_commands(CLI::App& app) {
  CLI::App& nn_group = subcommand_group(app, "nn", "Networks: weight files (safetensors), the diffusion UNet");
  CLI::App* gsm = nn_group.add_subcommand("gsm", "InfiniCube's feed-forward reconstruction model (GSM)");
  gsm->require_subcommand(1);
  auto a = std::make_shared<GsmForwardArgs>();
  CLI::App* fwd = gsm->add_subcommand("forward", "Run the GSM on a case folder (GPU, or the CPU reference); write its Gaussians and sky (.safetensors)");
  fwd->add_option("--model", a->model, "GSM config JSON (a case's config.json: hparams + dav2_config) or preset infinicube-gsm")->required()->type_name("CONFIG");
  fwd->add_option("--weights", a->weights, "Weights (.safetensors, gsm.Model.state_dict() names)")->required()->type_name("W");
  fwd->add_option("--inputs", a->inputs, "Case folder: images, masks, poses, intrinsics, voxel_ijk.b<i>, depth_patch_keep (.npy)")
      ->required()
      ->type_name("DIR");
  fwd->add_option("--backend", a->backend, "gpu (Vulkan kernels) or cpu (the exact double-accumulation reference)")
      ->check(CLI::IsMember({"gpu", "cpu"}))
      ->capture_default_str();
  fwd->add_option("--dump-layers", a->dump, "Also write every intermediate under the reference case's names")
      ->type_name("FILE.safetensors");
  fwd->add_option("-o,--output", a->output, "The outputs (gs.b<i>.voxel.*, gs.b<i>.pixel.*, sky.*)")->required()->type_name("OUT.safetensors");
  fwd->callback([a] { cmd_gsm_forward(*a); });
}

const CommandRegistrar kNnGsmRegistrar(add_gsm_commands, 52);

}  // namespace
}  // namespace icube::tools
