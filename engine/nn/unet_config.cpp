// UNet configuration from the official constructor's keyword arguments; see unet_config.h.
#include "nn/unet_config.h"

#include "scene/atomic_file.h"
#include "nn/kwargs_reader.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <functional>
#include <stdexcept>
#include <map>

namespace icube::nn {

using json = nlohmann::json;

UNetConfig infinicube_diffusion_config() { return UNetConfig{}; }

void check_unet_grid(const UNetConfig& c, int64_t X, int64_t Y, int64_t Z) {
  const int64_t m = c.grid_multiple();
  const int64_t dims[3] = {X, Y, Z};
  for (int a = 0; a < 3; ++a) {
    if (dims[a] >= m && dims[a] % m == 0) continue;
    const int64_t down = dims[a] / m * m, up = (dims[a] / m + 1) * m;
    throw std::invalid_argument(
        "UNet: input grid " + std::to_string(X) + "x" + std::to_string(Y) + "x" + std::to_string(Z) + ": axis " +
        "XYZ"[a] + " (" + std::to_string(dims[a]) + ") must be a positive multiple of " + std::to_string(m) +
        " (the model halves the grid " + std::to_string(c.channel_mult.size() - 1) + " times, channel_mult has " +
        std::to_string(c.channel_mult.size()) + " levels); pad or crop it to " +
        (down > 0 ? std::to_string(down) + " or " : std::string()) + std::to_string(up));
  }
}

UNetConfig parse_unet_config(const std::string& text, const std::string& source) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw scene::InputError(source, "", std::string("not valid JSON: ") + scene::printable(e.what(), 160));
  }
  if (j.is_object() && j.contains("unet_kwargs")) j = j["unet_kwargs"];
  if (!j.is_object()) throw scene::InputError(source, "", "is not a JSON object of UNetModel keyword arguments");
  const KwargsReader r{source};
  UNetConfig c;
  c.out_channels = -1;
  bool have_in = false, have_model = false, have_blocks = false, have_attn = false, have_image = false;
  const std::map<std::string, std::function<void(const json&)>> keys = {
      {"image_size", [&](const json& v) { c.image_size = r.integer("image_size", v); have_image = true; }},
      {"num_input_channels", [&](const json& v) { c.in_channels = r.integer("num_input_channels", v); have_in = true; }},
      {"out_channels", [&](const json& v) { c.out_channels = v.is_null() ? -1 : r.integer("out_channels", v); }},
      {"model_channels", [&](const json& v) { c.model_channels = r.integer("model_channels", v); have_model = true; }},
      {"num_res_blocks", [&](const json& v) { c.num_res_blocks = r.integer("num_res_blocks", v); have_blocks = true; }},
      {"attention_resolutions", [&](const json& v) {
         c.attention_resolutions = v.is_array() && v.empty() ? std::vector<int>{} : r.list("attention_resolutions", v);
         have_attn = true;
       }},
      {"channel_mult", [&](const json& v) { c.channel_mult = r.list("channel_mult", v); }},
      {"conv_resample", [&](const json& v) { c.conv_resample = r.boolean("conv_resample", v); }},
      {"dims", [&](const json& v) { c.dims = r.integer("dims", v); }},
      {"num_heads", [&](const json& v) { c.num_heads = r.integer("num_heads", v); }},
      {"num_head_channels", [&](const json& v) { c.num_head_channels = r.integer("num_head_channels", v); }},
      {"num_heads_upsample", [&](const json& v) { c.num_heads_upsample = r.integer("num_heads_upsample", v); }},
      {"use_scale_shift_norm", [&](const json& v) { c.use_scale_shift_norm = r.boolean("use_scale_shift_norm", v); }},
      {"resblock_updown", [&](const json& v) { c.resblock_updown = r.boolean("resblock_updown", v); }},
      {"use_spatial_transformer", [&](const json& v) { c.use_spatial_transformer = r.boolean("use_spatial_transformer", v); }},
      {"transformer_depth", [&](const json& v) { c.transformer_depth = r.integer("transformer_depth", v); }},
      {"legacy", [&](const json& v) { c.legacy = r.boolean("legacy", v); }},
      {"middile_force_spatial_transformer",
       [&](const json& v) { c.middle_force_spatial_transformer = r.boolean("middile_force_spatial_transformer", v); }},
      {"middle_disable_first_sa", [&](const json& v) { c.middle_disable_first_sa = r.boolean("middle_disable_first_sa", v); }},
      // Accepted, no effect on inference.
      {"dropout", [&](const json& v) { if (!v.is_number()) r.fail("dropout", "is not a number"); }},
      {"use_checkpoint", [&](const json& v) { r.boolean("use_checkpoint", v); }},
      {"use_fp16", [&](const json& v) { r.boolean("use_fp16", v); }},
      // Conditioning the released model does not use.
      {"num_classes", [&](const json& v) { r.null_only("num_classes", v, "class conditioning"); }},
      {"context_dim", [&](const json& v) { r.null_only("context_dim", v, "cross-attention conditioning"); }},
      {"n_embed", [&](const json& v) { r.null_only("n_embed", v, "codebook-id prediction"); }},
  };
  for (auto it = j.begin(); it != j.end(); ++it) {
    const auto k = keys.find(it.key());
    if (k == keys.end()) r.fail(scene::printable(it.key()), "is not a UNetModel argument this engine knows");
    k->second(it.value());
  }
  if (!have_image || !have_in || !have_model || !have_blocks || !have_attn)
    r.fail("", "needs image_size, num_input_channels, model_channels, num_res_blocks and attention_resolutions");
  if (c.dims != 3) r.fail("dims", std::to_string(c.dims) + ": only the dense 3-D UNet is implemented");
  if (c.use_spatial_transformer)
    r.fail("use_spatial_transformer", "true needs cross-attention conditioning, which is not implemented");
  if (c.in_channels < 1 || c.model_channels < 1 || c.num_res_blocks < 1 || c.outputs() < 1 || c.transformer_depth < 1)
    r.fail("", "channel counts, num_res_blocks and transformer_depth must be positive");
  if (c.num_heads == -1 && c.num_head_channels == -1) r.fail("num_heads", "either num_heads or num_head_channels must be set");
  for (const int m : c.channel_mult) {
    const int ch = m * c.model_channels;
    if (ch % 32 != 0) r.fail("channel_mult", "channels " + std::to_string(ch) + " are not a multiple of GroupNorm's 32 groups");
    if (c.num_head_channels > 0 && ch % c.num_head_channels != 0)
      r.fail("num_head_channels", std::to_string(ch) + " channels are not divisible by it");
    if (c.num_head_channels == -1 && c.num_heads > 0 && ch % c.num_heads != 0)
      r.fail("num_heads", std::to_string(ch) + " channels are not divisible by it");
  }
  if (c.model_channels % 2 != 0) r.fail("model_channels", "must be even (the sinusoidal embedding)");
  return c;
}

// The released structure cut down to a smoke-test size: 32 channels, four levels (the middle at 8^3 of a
// 64^3 latent, so no attention over many tokens), one ResBlock a level, no attention blocks.
const char* const kTinyDiffusion = R"({"unet_kwargs": {"image_size": 64, "num_input_channels": 16, "out_channels": 8,
  "model_channels": 32, "num_res_blocks": 1, "attention_resolutions": [], "channel_mult": [1, 1, 1, 1], "num_heads": 4,
  "use_scale_shift_norm": true, "resblock_updown": true, "legacy": true, "middile_force_spatial_transformer": false,
  "dropout": 0.0}})";

UNetConfig load_unet_config(const std::string& path_or_preset) {
  if (path_or_preset == "infinicube-diffusion") return infinicube_diffusion_config();
  if (path_or_preset == "infinicube-diffusion-tiny") return parse_unet_config(kTinyDiffusion, "preset infinicube-diffusion-tiny");
  return parse_unet_config(scene::read_file(path_or_preset), path_or_preset);
}

}  // namespace icube::nn
