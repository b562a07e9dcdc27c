// `icube nn` : the network layer's weights.
//
//   icube nn info WEIGHTS.safetensors [--model CONFIG|PRESET [--ema] | --gsm-model CONFIG|infinicube-gsm]
//                 [--check-finite] [--limit N]
//   icube nn forward --model CONFIG|PRESET --weights W.safetensors --input x.npy --timestep t.npy
//                    [--backend gpu|cpu] [--precision fp32|fp16-weights|fp16] [--ema] [--check-finite] [--dump-layers FILE.safetensors] -o y.npy
//   icube nn random-weights (--model CONFIG|PRESET | --vae-model CONFIG|PRESET | --gsm-model CONFIG|infinicube-gsm)
//                           [--seed N] [--scale-factor S] -o W.safetensors
//
// info validates the file (engine/nn/safetensors.h: header, dtypes, shapes,
// ranges), lists its tensors and the totals per name prefix (`unet.`,
// `unet_ema.`, `vae.` in a converted Lightning checkpoint), and with --model
// checks it holds exactly the model's parameters (engine/nn/weights.h); with
// --gsm-model exactly the GSM's state dict (engine/nn/gsm/gsm_params.h: every
// tensor, its shape and dtype, nothing else).
// forward runs the dense diffusion UNet on .npy inputs (x [B, C, X, Y, Z]
// float32, t [B] int64) on the GPU (engine/nn/unet_gpu.h, default) or with the
// CPU reference (--backend cpu, engine/nn/unet_reference.h: double
// accumulation, slow); --dump-layers writes every block's output under
// the names of unet_small/*.intermediates.safetensors. Outputs are written
// atomically. Any NaN/Inf with --check-finite, missing or extra tensor, or
// wrong shape is a one-line error naming the file and the tensor.
// random-weights writes a seeded random-weight model of the official
// structure (engine/nn/random_weights.h: the UNet, or the whole structure
// VAE; engine/nn/gsm/gsm_random_weights.h: the GSM, in state-dict order with
// int64 num_batches_tracked), for smoke tests and benchmarks of the pipeline
// without a checkpoint (the released GSM is 361 M parameters, 1.44 GB of fp32);
// --scale-factor goes into the metadata as the converter writes it.
#include "cli_common.h"
#include "command_registry.h"

#include "nn/gsm/gsm_params.h"
#include "nn/gsm/gsm_random_weights.h"
#include "nn/random_weights.h"
#include "nn/safetensors.h"
#include "nn/vae_config.h"
#include "gpu/context.h"
#include "nn/unet_config.h"
#include "nn/unet_gpu.h"
#include "nn/unet_reference.h"
#include "nn/weights.h"
#include "scene/input_error.h"
#include "world/npy.h"

#include <CLI/CLI.hpp>

#include <cmath>
#include <unistd.h>
#include <optional>
#include <cstdio>
#include <map>
#include <memory>
#include <string>

namespace icube::tools {
namespace {

struct NnInfoArgs {
  std::string weights, model, gsm_model;
  bool check_finite = false, ema = false;
  size_t limit = 50;
};

struct NnForwardArgs {
  std::string model, weights, input, timestep, dump, output, backend = "gpu", precision = "fp32";
  bool ema = false, check_finite = false;
};

void cmd_nn_forward(const NnForwardArgs& a) {
  run_command([&](scene::Diagnostics&) {
    const nn::UNetConfig cfg = nn::load_unet_config(a.model);
    nn::UNetReference net(cfg);
    const nn::SafetensorsFile file(a.weights);
    nn::WeightOptions wo;
    wo.ema = a.ema;
    wo.check_finite = a.check_finite;
    std::map<std::string, nn::CpuTensor> weights = nn::load_weights_cpu(file, net.parameters(), wo);
    std::optional<gpu::Context> ctx;
    std::unique_ptr<nn::UNetGpu> gpu_net;
    const nn::NetworkPrecision precision = nn::parse_network_precision(a.precision, a.backend);
    if (a.backend == "gpu") {
      ctx.emplace(gpu::ContextOptions::from_env());
      gpu_net = std::make_unique<nn::UNetGpu>(
          *ctx, cfg, weights, precision);
    } else {
      net.set_weights(std::move(weights));
    }
    const world::NpyArray x = world::read_npy(a.input);
    if (x.dtype != world::NpyDtype::F4 || x.shape.size() != 5 || x.shape[1] != static_cast<uint64_t>(cfg.in_channels))
      throw scene::InputError(a.input, "", "expected float32 [B, " + std::to_string(cfg.in_channels) + ", X, Y, Z]");
    const world::NpyArray t = world::read_npy(a.timestep);
    if (t.dtype != world::NpyDtype::I8 || t.shape != std::vector<uint64_t>{x.shape[0]})
      throw scene::InputError(a.timestep, "", "expected int64 [" + std::to_string(x.shape[0]) + "] (one timestep per batch element)");
    const std::vector<float> xv = x.values<float>();
    for (size_t i = 0; i < xv.size(); ++i)
      if (!std::isfinite(xv[i])) throw scene::InputError(a.input, "element " + std::to_string(i), "is not finite");
    std::vector<nn::TensorToWrite> dumped;
    const nn::UNetReference::Capture capture = [&](const std::string& name, const nn::CpuTensor& v) {
      dumped.push_back(nn::f32_tensor(name, v.shape, v.data));
    };
    std::fprintf(stderr, "nn forward: %llu parameters, input [%llu, %llu, %llu, %llu, %llu], %s\n",
                 static_cast<unsigned long long>(net.parameter_count()), static_cast<unsigned long long>(x.shape[0]),
                 static_cast<unsigned long long>(x.shape[1]), static_cast<unsigned long long>(x.shape[2]),
                 static_cast<unsigned long long>(x.shape[3]), static_cast<unsigned long long>(x.shape[4]),
                 gpu_net ? ("GPU: " + ctx->info().name).c_str() : "CPU reference");
    const nn::CpuTensor xin(std::vector<int64_t>(x.shape.begin(), x.shape.end()), xv);
    const nn::UNetReference::Capture cap = a.dump.empty() ? nn::UNetReference::Capture{} : capture;
    const nn::CpuTensor y = gpu_net ? gpu_net->forward(xin, t.values<int64_t>(), cap) : net.forward(xin, t.values<int64_t>(), cap);
    if (gpu_net)
      std::fprintf(stderr, "nn forward: %.1f MiB of activations (peak) and %.1f MiB of %s weights on the device%s\n",
                   static_cast<double>(gpu_net->last_activation_bytes()) / (1024.0 * 1024.0),
                   static_cast<double>(gpu_net->weight_bytes()) / (1024.0 * 1024.0),
                   a.precision == "fp32" ? "fp32" : "fp16 (conv/linear)",
                   a.precision == "fp16" ? "; convolution operands (the norms' outputs) in fp16" : "");
    std::vector<uint64_t> ys(y.shape.begin(), y.shape.end());
    if (!a.dump.empty()) nn::write_safetensors(a.dump, dumped, {{"layout", "block outputs [B, C, X, Y, Z]"}});
    world::write_npy(a.output, world::NpyArray::make<float>(ys, y.data));
    std::printf("nn forward: wrote %s [%llu, %llu, %llu, %llu, %llu]%s\n", a.output.c_str(),
                static_cast<unsigned long long>(ys[0]), static_cast<unsigned long long>(ys[1]),
                static_cast<unsigned long long>(ys[2]), static_cast<unsigned long long>(ys[3]),
                static_cast<unsigned long long>(ys[4]), a.dump.empty() ? "" : (" and " + a.dump).c_str());
  });
}

void cmd_nn_info(const NnInfoArgs& a) {
  run_command([&](scene::Diagnostics&) {
    const nn::SafetensorsFile f(a.weights);
    if (!a.model.empty() && !a.gsm_model.empty()) throw std::invalid_argument("give --model (a UNet) or --gsm-model, not both");
    if (!a.gsm_model.empty()) {
      const std::vector<nn::GsmParamSpec> specs = nn::gsm_param_specs(nn::load_gsm_model_config(a.gsm_model));
      nn::check_gsm_weight_file(f, specs);
      std::printf("%s: holds every tensor of the GSM %s (%zu tensors: %llu parameters, %llu buffer elements)\n",
                  a.weights.c_str(), a.gsm_model.c_str(), specs.size(),
                  static_cast<unsigned long long>(nn::gsm_parameter_count(specs)),
                  static_cast<unsigned long long>(nn::gsm_buffer_count(specs)));
    }
    if (!a.model.empty()) {
      const nn::UNetReference net(nn::load_unet_config(a.model));
      nn::WeightOptions wo;
      wo.ema = a.ema;
      (void)nn::resolve_weights(f, net.parameters(), wo);
      std::printf("%s: holds every parameter of %s (%zu tensors, %llu parameters)%s\n", a.weights.c_str(),
                  a.model.c_str(), net.parameters().size(), static_cast<unsigned long long>(net.parameter_count()),
                  a.ema ? ", EMA copy" : "");
    }
    if (a.check_finite)
      for (const nn::TensorInfo& t : f.tensors())
        if (const int64_t i = f.first_non_finite(t); i >= 0)
          throw scene::InputError(a.weights, "tensor '" + scene::printable(t.name) + "'",
                                  "element " + std::to_string(i) + " is not finite (NaN or infinity)");
    std::printf("%s: %zu tensors, %.2f MB of data, header %llu bytes\n", a.weights.c_str(), f.tensors().size(),
                static_cast<double>(f.data_bytes()) * 1e-6, static_cast<unsigned long long>(f.header_bytes()));
    for (const auto& [k, v] : f.metadata()) std::printf("  metadata %s = %s\n", k.c_str(), scene::printable(v, 80).c_str());
    std::map<std::string, std::pair<size_t, uint64_t>> prefixes;  // first name component -> tensors, elements
    uint64_t total = 0;
    size_t shown = 0;
    for (const nn::TensorInfo& t : f.tensors()) {
      const std::string prefix = t.name.substr(0, t.name.find('.'));
      prefixes[prefix].first += 1;
      prefixes[prefix].second += t.numel();
      total += t.numel();
      if (a.limit == 0 || shown < a.limit) {
        std::printf("  %-60s %-4s %-22s %12llu\n", scene::printable(t.name, 60).c_str(), nn::dtype_name(t.dtype),
                    t.shape_text().c_str(), static_cast<unsigned long long>(t.numel()));
        ++shown;
      }
    }
    if (shown < f.tensors().size()) std::printf("  ... %zu more (--limit 0 lists all)\n", f.tensors().size() - shown);
    std::printf("by prefix:\n");
    for (const auto& [p, c] : prefixes)
      std::printf("  %-30s %6zu tensors %14llu parameters\n", scene::printable(p, 30).c_str(), c.first,
                  static_cast<unsigned long long>(c.second));
    std::printf("total: %llu parameters%s\n", static_cast<unsigned long long>(total),
                a.check_finite ? ", all finite" : "");
  });
}

struct RandomWeightsArgs {
  std::string model, vae_model, gsm_model, output;
  uint32_t seed = 0;
  double scale_factor = 0.0;
};

// The model's parameters and the memory random-weights needs (every tensor as float32, and its
// copy for the file), checked against this machine's memory before anything is allocated.
void check_random_weights_size(const std::vector<nn::ParamSpec>& specs, const std::string& config, const std::string& reduce) {
  double params = 0.0;
  for (const nn::ParamSpec& s : specs) {
    double n = 1.0;
    for (const int64_t d : s.shape) n *= static_cast<double>(d);
    params += n;
  }
  const double need = params * 4.0 * 2.0;
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  const double have = pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 0.0;
  if (have > 0.0 && need > 0.8 * have) {
    char text[320];
    std::snprintf(text, sizeof(text),
                  "%s: %.3g parameters need ~%.3g GiB to generate and write (float32 and the file's copy), over 80 %% "
                  "of this machine's %.1f GiB; reduce %s",
                  config.c_str(), params, need / double(1ull << 30), have / double(1ull << 30), reduce.c_str());
    throw std::invalid_argument(text);
  }
}

// The GSM's random weights (state-dict order, int64 batch counts), its size stated before the work.
void write_gsm_random_weights(const RandomWeightsArgs& a) {
  const std::vector<nn::GsmParamSpec> specs = nn::gsm_param_specs(nn::load_gsm_model_config(a.gsm_model));
  check_random_weights_size(std::vector<nn::ParamSpec>(specs.begin(), specs.end()), a.gsm_model,
                            "the widths in its hparams and dav2_config");
  const uint64_t params = nn::gsm_parameter_count(specs), buffers = nn::gsm_buffer_count(specs);
  std::fprintf(stderr, "random-weights: the GSM %s: %zu tensors, %llu parameters + %llu buffer elements = %.2f GB of float32\n",
               a.gsm_model.c_str(), specs.size(), static_cast<unsigned long long>(params),
               static_cast<unsigned long long>(buffers), static_cast<double>(params + buffers) * 4e-9);
  std::vector<nn::TensorToWrite> tensors = nn::gsm_weight_file_tensors(nn::gsm_random_weights(specs, a.seed), specs);
  nn::write_safetensors(a.output, tensors,
                        {{"source", "icube nn random-weights seed " + std::to_string(a.seed)},
                         {"format", "gsm.Model state_dict names (" + a.gsm_model + ")"}});
  std::printf("random-weights: %zu tensors, %llu parameters (seed %u) -> %s\n", tensors.size(),
              static_cast<unsigned long long>(params), a.seed, a.output.c_str());
}

void cmd_random_weights(const RandomWeightsArgs& a) {
  run_command([&](scene::Diagnostics&) {
    if (a.model.empty() + a.vae_model.empty() + a.gsm_model.empty() != 2)
      throw std::invalid_argument("give one of --model (a UNet), --vae-model (a VAE) or --gsm-model (the GSM)");
    if (a.scale_factor < 0.0 || !std::isfinite(a.scale_factor))
      throw std::invalid_argument("--scale-factor " + std::to_string(a.scale_factor) + " is not a positive number");
    if (!a.gsm_model.empty()) {
      if (a.scale_factor > 0.0) throw std::invalid_argument("--scale-factor is the diffusion latent's, not the GSM's");
      write_gsm_random_weights(a);
      return;
    }
    const std::vector<nn::ParamSpec> specs = a.model.empty()
                                                 ? nn::vae_param_specs(nn::load_vae_config(a.vae_model), nn::VaePart::All)
                                                 : nn::UNetReference(nn::load_unet_config(a.model)).parameters();
    check_random_weights_size(specs, a.model.empty() ? a.vae_model : a.model,
                              a.model.empty() ? "the VAE's channel counts (its config's channel keys)"
                                              : "model_channels (or channel_mult, num_res_blocks)");
    std::vector<nn::TensorToWrite> tensors;
    uint64_t params = 0;
    for (const auto& [name, w] : nn::random_weights(specs, a.seed)) {
      tensors.push_back(nn::f32_tensor(name, w.shape, w.data));
      params += w.data.size();
    }
    std::map<std::string, std::string> meta{{"source", "icube nn random-weights seed " + std::to_string(a.seed)}};
    if (a.scale_factor > 0.0) {
      char text[40];
      std::snprintf(text, sizeof(text), "%.17g", a.scale_factor);
      meta["scale_factor"] = text;
    }
    nn::write_safetensors(a.output, tensors, meta);
    std::printf("random-weights: %zu tensors, %llu parameters (seed %u) -> %s\n", tensors.size(),
                static_cast<unsigned long long>(params), a.seed, a.output.c_str());
  });
}

void add_nn_commands(CLI::App& app) {
  CLI::App& group = subcommand_group(app, "nn", "Networks: weight files (safetensors), the diffusion UNet");
  auto a = std::make_shared<NnInfoArgs>();
  CLI::App* cmd = group.add_subcommand("info", "Validate a .safetensors file and list its tensors");
  cmd->add_option("weights", a->weights, "Weights (.safetensors)")->required()->type_name("WEIGHTS");
  cmd->add_option("--model", a->model, "Check against a UNet config JSON or preset (infinicube-diffusion)")
      ->type_name("CONFIG");
  cmd->add_flag("--ema", a->ema, "With --model: check the EMA copy (unet_ema.*)");
  cmd->add_option("--gsm-model", a->gsm_model,
                  "Check against the GSM's state dict: a GSM config JSON (hparams + dav2_config) or preset infinicube-gsm")
      ->type_name("CONFIG");
  cmd->add_flag("--check-finite", a->check_finite, "Fail on the first NaN or infinity, naming the tensor");
  cmd->add_option("--limit", a->limit, "List at most N tensors (0 = all)")->capture_default_str()->type_name("N");
  cmd->callback([a] { cmd_nn_info(*a); });

  auto f = std::make_shared<NnForwardArgs>();
  CLI::App* fwd = group.add_subcommand("forward", "Run the diffusion UNet on .npy inputs (GPU, or the CPU reference)");
  fwd->add_option("--model", f->model, "UNet config JSON (official UNetModel kwargs) or preset infinicube-diffusion")
      ->required()
      ->type_name("CONFIG");
  fwd->add_option("--weights", f->weights, "Weights (.safetensors; bare, unet.* or unet_ema.* names)")->required()->type_name("W");
  fwd->add_option("--input", f->input, "x: float32 [B, C, X, Y, Z]")->required()->type_name("X.npy");
  fwd->add_option("--timestep", f->timestep, "t: int64 [B]")->required()->type_name("T.npy");
  fwd->add_flag("--ema", f->ema, "Use the EMA copy of the weights");
  fwd->add_option("--precision", f->precision,
                  nn::network_precision_help())
      ->check(CLI::IsMember({"fp32", "fp16-weights", "fp16"}))
      ->capture_default_str();
  fwd->add_option("--backend", f->backend, "gpu (Vulkan kernels) or cpu (the exact double-accumulation reference)")
      ->check(CLI::IsMember({"gpu", "cpu"}))
      ->capture_default_str();
  fwd->add_flag("--check-finite", f->check_finite, "Fail on a NaN or infinity in the weights");
  fwd->add_option("--dump-layers", f->dump, "Write every block's output (official names) to this .safetensors")
      ->type_name("FILE");
  fwd->add_option("-o,--output", f->output, "y: float32 [B, out_channels, X, Y, Z]")->required()->type_name("Y.npy");
  fwd->callback([f] { cmd_nn_forward(*f); });
}

const CommandRegistrar kNnRegistrar(add_nn_commands, 50);

void add_random_weights_command(CLI::App& app) {
  CLI::App& group = subcommand_group(app, "nn", "Networks: weight files (safetensors), the diffusion UNet");
  auto r = std::make_shared<RandomWeightsArgs>();
  CLI::App* cmd = group.add_subcommand("random-weights", "Write a seeded random-weight model of the official structure");
  cmd->add_option("--model", r->model, "UNet config JSON or preset infinicube-diffusion")->type_name("CONFIG");
  cmd->add_option("--vae-model", r->vae_model, "Structure VAE config JSON or preset infinicube-vae")->type_name("CONFIG");
  cmd->add_option("--gsm-model", r->gsm_model, "GSM config JSON (hparams + dav2_config) or preset infinicube-gsm")
      ->type_name("CONFIG");
  cmd->add_option("--seed", r->seed, "Seed")->capture_default_str();
  cmd->add_option("--scale-factor", r->scale_factor, "Write this latent scale_factor into the metadata")->type_name("S");
  cmd->add_option("-o,--output", r->output, "Weights file")->required()->type_name("W.safetensors");
  cmd->callback([r] { cmd_random_weights(*r); });
}

const CommandRegistrar kRandomWeightsRegistrar(add_random_weights_command, 52);

}  // namespace
}  // namespace icube::tools
