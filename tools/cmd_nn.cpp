// `icube nn` : the network layer's weights.
//
//   icube nn info WEIGHTS.safetensors [--check-finite] [--limit N]
//
// Validates the file (engine/nn/safetensors.h: header, dtypes, shapes,
// ranges), lists its tensors (name, dtype, shape, elements) and the totals
// per name prefix (`unet.`, `unet_ema.`, `vae.` in a converted Lightning
// checkpoint). With --check-finite a NaN or infinity in any tensor is an error
// naming the tensor and the element. Checking against a model config comes
// with the models (issue 16).
#include "cli_common.h"
#include "command_registry.h"

#include "nn/safetensors.h"
#include "scene/input_error.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <map>
#include <memory>
#include <string>

namespace icube::tools {
namespace {

struct NnInfoArgs {
  std::string weights;
  bool check_finite = false;
  size_t limit = 50;
};

void cmd_nn_info(const NnInfoArgs& a) {
  run_command([&](scene::Diagnostics&) {
    const nn::SafetensorsFile f(a.weights);
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

void add_nn_commands(CLI::App& app) {
  CLI::App& group = subcommand_group(app, "nn", "Networks: weight files (safetensors)");
  auto a = std::make_shared<NnInfoArgs>();
  CLI::App* cmd = group.add_subcommand("info", "Validate a .safetensors file and list its tensors");
  cmd->add_option("weights", a->weights, "Weights (.safetensors)")->required()->type_name("WEIGHTS");
  cmd->add_flag("--check-finite", a->check_finite, "Fail on the first NaN or infinity, naming the tensor");
  cmd->add_option("--limit", a->limit, "List at most N tensors (0 = all)")->capture_default_str()->type_name("N");
  cmd->callback([a] { cmd_nn_info(*a); });
}

const CommandRegistrar kRegistrar(add_nn_commands, 50);

}  // namespace
}  // namespace icube::tools
