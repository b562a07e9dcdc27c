// The options of Stage 3 with the learned GSM (engine/lift/gsm_lift.h), registered the same way by
// `icube lift` and `icube generate`:
//   --gsm DIR                         a model folder as tools/convert_checkpoint.py writes it
//                                     (gsm_config.json + gsm.safetensors)
//   --gsm-model CONFIG|infinicube-gsm --gsm-weights W
//                                     the same as two paths (a config JSON or the released preset;
//                                     `icube nn gsm forward`'s --model / --weights)
//   --gsm-size WxH                    the model's input size (the key frames resized to it); default the
//                                     frames' size, which must then be multiples of 16
//   --gsm-radius M                    input voxels within M metres of a key camera (0 = the whole world)
//   --gsm-backend gpu|cpu             the GPU forward or the plain CPU reference
// With the GSM the key-frame interval defaults to the official 6 unless --key-every is given.
#pragma once

#include "lift/gsm_lift.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

namespace icube::tools {

struct GsmCliArgs {
  std::string dir, model, weights, size, backend = "gpu";
  double radius = lift::GsmLiftOptions{}.radius;
  CLI::Option* key_every = nullptr;  // the command's --key-every (its default changes with the GSM)
};

inline void add_gsm_options(CLI::App* cmd, GsmCliArgs& a) {
  cmd->add_option("--gsm", a.dir,
                  "Stage 3 with the learned GSM: a model folder holding gsm_config.json and gsm.safetensors "
                  "(tools/convert_checkpoint.py); without it the non-learned lift runs")
      ->type_name("DIR");
  cmd->add_option("--gsm-model", a.model, "The GSM's config JSON or preset infinicube-gsm (with --gsm-weights, instead of --gsm)")
      ->type_name("CONFIG");
  cmd->add_option("--gsm-weights", a.weights, "The GSM's weights (.safetensors, gsm.Model.state_dict() names; with --gsm-model)")
      ->type_name("W");
  cmd->add_option("--gsm-size", a.size,
                  "The GSM's input size, multiples of 16 (the key frames are resized to it; default their own size; "
                  "the official input is 832x480)")
      ->type_name("WxH");
  cmd->add_option("--gsm-radius", a.radius,
                  "The GSM's input voxels: those within this many metres (x, y) of a key camera (0 = the whole world)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e7));
  cmd->add_option("--gsm-backend", a.backend, "gpu (Vulkan kernels) or cpu (the plain CPU reference, slow)")
      ->check(CLI::IsMember({"gpu", "cpu"}))
      ->capture_default_str();
}

inline bool gsm_requested(const GsmCliArgs& a) { return !a.dir.empty() || !a.model.empty() || !a.weights.empty(); }

// The model's files; nullopt without the GSM options. std::invalid_argument for a bad combination.
inline std::optional<lift::GsmModelPaths> gsm_paths_of(const GsmCliArgs& a) {
  if (!gsm_requested(a)) return std::nullopt;
  if (!a.dir.empty() && (!a.model.empty() || !a.weights.empty()))
    throw std::invalid_argument("give --gsm DIR or --gsm-model with --gsm-weights, not both");
  if (!a.dir.empty()) return lift::gsm_model_paths(a.dir);
  if (a.model.empty() || a.weights.empty()) throw std::invalid_argument("--gsm-model and --gsm-weights go together");
  return lift::GsmModelPaths{a.model, a.weights};
}

// The settings of the options into `o` (key_every: 6 unless --key-every was given).
inline void apply_gsm_options(const GsmCliArgs& a, size_t key_every, lift::GsmLiftOptions& o) {
  o.key_every = a.key_every && a.key_every->count() > 0 ? key_every : lift::GsmLiftOptions{}.key_every;
  o.radius = a.radius;
  o.cpu_reference = a.backend == "cpu";
  o.width = o.height = 0;
  if (!a.size.empty()) {
    unsigned w = 0, h = 0;
    char x = 0, extra = 0;
    if (std::sscanf(a.size.c_str(), "%u%c%u%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') || w == 0 || h == 0 ||
        w > 16384 || h > 16384)
      throw std::invalid_argument("--gsm-size: '" + a.size + "' is not WxH (e.g. 832x480)");
    o.width = w;
    o.height = h;
  }
}

}  // namespace icube::tools
