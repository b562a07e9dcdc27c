// Structure VAE configuration and parameter list; see vae_config.h.
#include "nn/vae_config.h"

#include "scene/atomic_file.h"
#include "nn/kwargs_reader.h"
#include "scene/input_error.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <functional>
#include <map>

namespace icube::nn {

namespace {

using json = nlohmann::json;

// ConvBlock(in, out): GroupNorm over `in` channels when g precedes c, else over `out`.
void conv_block(std::vector<ParamSpec>& p, const VaeConfig& c, const std::string& name, int in, int out) {
  const size_t ci = c.order.find('c');
  for (size_t i = 0; i < c.order.size(); ++i) {
    if (c.order[i] == 'g') {
      const int64_t ch = i < ci ? in : out;
      p.push_back({name + ".GroupNorm.weight", {ch}});
      p.push_back({name + ".GroupNorm.bias", {ch}});
    } else if (c.order[i] == 'c') {
      p.push_back({name + ".Conv.weight", {out, in, 3, 3, 3}});
      if (c.order.find('g') == std::string::npos) p.push_back({name + ".Conv.bias", {out}});
    }
  }
}

// SparseResBlock: encoder blocks widen in conv1 to max(out / 2, in); 1x1 skip (with bias) when in != out.
void res_block(std::vector<ParamSpec>& p, const VaeConfig& c, const std::string& name, int in, int out, bool encoder) {
  const int mid = encoder ? std::max(out / 2, in) : out;
  conv_block(p, c, name + ".conv1", in, mid);
  conv_block(p, c, name + ".conv2", mid, out);
  if (in != out) {
    p.push_back({name + ".skip_connection.weight", {out, in}});
    p.push_back({name + ".skip_connection.bias", {out}});
  }
}

void head(std::vector<ParamSpec>& p, const VaeConfig& c, const std::string& name, int in, int out) {
  conv_block(p, c, name + ".SingleConv", in, in);
  p.push_back({name + ".OutConv.weight", {out, in}});
  p.push_back({name + ".OutConv.bias", {out}});
}

}  // namespace

std::vector<int> VaeConfig::features() const {
  std::vector<int> n{in_channels};
  for (int k = 0; k < num_blocks; ++k) n.push_back(f_maps << k);
  return n;
}

Ijk VaeConfig::pool_factor(int level) const {
  const bool all = pooling_level.empty();
  const bool cube = all || std::find(pooling_level.begin(), pooling_level.end(), level) != pooling_level.end();
  return cube ? Ijk{2, 2, 2} : Ijk{2, 2, 1};
}

Ijk VaeConfig::subdivide_factor(int level) const { return pool_factor(level + 1); }

VaeConfig infinicube_vae_config() { return VaeConfig{}; }

VaeConfig parse_vae_config(const std::string& text, const std::string& source) {
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception& e) {
    throw scene::InputError(source, "", std::string("not valid JSON: ") + scene::printable(e.what(), 160));
  }
  if (!root.is_object()) throw scene::InputError(source, "", "is not a JSON object of StructPredictionNet keyword arguments");
  const json j = root.contains("vae_kwargs") ? root["vae_kwargs"] : root;
  if (!j.is_object()) throw scene::InputError(source, "vae_kwargs", "is not a JSON object");
  const KwargsReader r{source};
  VaeConfig c;
  bool have_in = false, have_blocks = false;
  c.f_maps = 64;
  c.order = "gcr";  // the constructor's defaults
  c.pooling_level.clear();
  c.neck_dense = false;
  c.cut_ratio = 1;
  c.neck_bound = {4, 4, 4};
  c.with_semantic_branch = false;
  const std::map<std::string, std::function<void(const json&)>> keys = {
      {"in_channels", [&](const json& v) { c.in_channels = r.integer("in_channels", v, 1); have_in = true; }},
      {"num_blocks", [&](const json& v) { c.num_blocks = r.integer("num_blocks", v, 1, 8); have_blocks = true; }},
      {"f_maps", [&](const json& v) { c.f_maps = r.integer("f_maps", v, 1); }},
      {"order", [&](const json& v) {
         if (!v.is_string()) r.fail("order", "is not a string");
         c.order = v.get<std::string>();
       }},
      {"num_groups", [&](const json& v) { c.num_groups = r.integer("num_groups", v, 1); }},
      {"pooling", [&](const json& v) {
         if (!v.is_string() || v.get<std::string>() != "max") r.fail("pooling", "only \"max\" is implemented");
       }},
      {"pooling_level", [&](const json& v) {
         if (!v.is_array()) r.fail("pooling_level", "is not a list of levels");
         c.pooling_level.clear();
         for (const json& e : v) c.pooling_level.push_back(r.integer("pooling_level", e, 0, 64));
       }},
      {"neck_dense_type", [&](const json& v) {
         const std::string t = v.is_string() ? v.get<std::string>() : "";
         if (t != "HAND_CRAFTED" && t != "UNCHANGED") r.fail("neck_dense_type", "is not \"HAND_CRAFTED\" or \"UNCHANGED\"");
         c.neck_dense = t == "HAND_CRAFTED";
       }},
      {"cut_ratio", [&](const json& v) { c.cut_ratio = r.integer("cut_ratio", v, 1); }},
      {"neck_bound", [&](const json& v) {
         if (v.is_number_integer()) {
           const int b = r.integer("neck_bound", v, 1, 4096);
           c.neck_bound = {b, b, b};
         } else if (v.is_array() && v.size() == 3) {
           for (int d = 0; d < 3; ++d) c.neck_bound[d] = r.integer("neck_bound", v[d], 1, 4096);
         } else {
           r.fail("neck_bound", "is not an integer or a list of three");
         }
       }},
      {"with_semantic_branch", [&](const json& v) { c.with_semantic_branch = r.boolean("with_semantic_branch", v); }},
      {"num_semantic_classes", [&](const json& v) { c.num_semantic_classes = r.integer("num_semantic_classes", v, 1); }},
      {"num_res_blocks", [&](const json& v) { c.num_res_blocks = r.integer("num_res_blocks", v, 1, 16); }},
      {"with_normal_branch", [&](const json& v) { r.must_be("with_normal_branch", v, false, "the normal head"); }},
      {"with_color_branch", [&](const json& v) { r.must_be("with_color_branch", v, false, "the colour head"); }},
      {"use_attention", [&](const json& v) { r.must_be("use_attention", v, false, "sparse attention in the bottleneck"); }},
      {"use_residual", [&](const json& v) { r.must_be("use_residual", v, true, "the non-residual SparseDoubleConv"); }},
      {"is_add_dec", [&](const json& v) { r.must_be("is_add_dec", v, true, "is_add_dec false (single decoder blocks)"); }},
      {"unstable_cutoff", [&](const json& v) { r.must_be("unstable_cutoff", v, false, "the training-time unstable cutoff"); }},
      {"unstable_cutoff_threshold", [&](const json& v) { if (!v.is_number()) r.fail("unstable_cutoff_threshold", "is not a number"); }},
      {"use_checkpoint", [&](const json& v) { r.boolean("use_checkpoint", v); }},
  };
  for (auto it = j.begin(); it != j.end(); ++it) {
    const auto k = keys.find(it.key());
    if (k == keys.end()) r.fail(scene::printable(it.key()), "is not a StructPredictionNet argument this engine knows");
    k->second(it.value());
  }
  if (!have_in || !have_blocks) r.fail("", "needs in_channels and num_blocks");
  if (root.contains("encoder_kwargs")) {
    const json& e = root["encoder_kwargs"];
    if (!e.is_object()) r.fail("encoder_kwargs", "is not a JSON object");
    for (auto it = e.begin(); it != e.end(); ++it) {
      const std::string key = "encoder_kwargs." + scene::printable(it.key());
      if (it.key() == "num_semantic") c.num_semantic = r.integer(key, it.value(), 1);
      else if (it.key() == "dim_semantic") c.dim_semantic = r.integer(key, it.value(), 1);
      else if (it.key() == "use_input_semantic") r.must_be(key, it.value(), true, "an encoder without semantics");
      else if (it.key() == "use_input_normal" || it.key() == "use_input_intensity" || it.key() == "use_input_color")
        r.must_be(key, it.value(), false, it.key().substr(10) + " input");
      else r.fail(key, "is not an encoder setting this engine knows");
    }
  }
  // The ConvBlock order: each of g, c and one activation at most once, c present.
  if (c.order.find('c') == std::string::npos) r.fail("order", "'" + scene::printable(c.order) + "' has no convolution 'c'");
  for (const char ch : c.order)
    if (std::string("gcsr").find(ch) == std::string::npos || std::count(c.order.begin(), c.order.end(), ch) > 1)
      r.fail("order", "'" + scene::printable(c.order) + "' is not made of g, c, s, r each at most once");
  if (c.features().back() % c.cut_ratio != 0 || c.latent_channels() < 1)
    r.fail("cut_ratio", std::to_string(c.features().back()) + " channels do not divide by it");
  for (const int ch : c.features())
    if (ch >= c.num_groups && ch % c.num_groups != 0)
      r.fail("num_groups", std::to_string(ch) + " channels do not divide into " + std::to_string(c.num_groups) + " groups");
  if (!c.with_semantic_branch) r.fail("with_semantic_branch", "false leaves the decoder without its output head");
  return c;
}

// The released structure at f_maps 8 (0.36 M parameters): the same levels, pooling and latent shape.
const char* const kTinyVae = R"({"vae_kwargs": {"in_channels": 32, "num_blocks": 3, "f_maps": 8, "cut_ratio": 4,
  "neck_dense_type": "HAND_CRAFTED", "neck_bound": [32, 32, 32], "num_res_blocks": 1, "use_residual": true,
  "order": "gcs", "is_add_dec": true, "use_attention": false, "use_checkpoint": false, "pooling_level": [2],
  "with_semantic_branch": true, "with_normal_branch": false}})";

VaeConfig load_vae_config(const std::string& path_or_preset) {
  if (path_or_preset == "infinicube-vae") return infinicube_vae_config();
  if (path_or_preset == "infinicube-vae-tiny") return parse_vae_config(kTinyVae, "preset infinicube-vae-tiny");
  return parse_vae_config(scene::read_file(path_or_preset), path_or_preset);
}

std::vector<ParamSpec> vae_param_specs(const VaeConfig& c, VaePart part) {
  std::vector<ParamSpec> p;
  const std::vector<int> n = c.features();
  const int nb = c.num_blocks, top = n.back(), latent = c.latent_channels();
  if (part != VaePart::Decoder) {
    p.push_back({"encoder.semantic_embed_fn.weight", {c.num_semantic, c.dim_semantic}});
    p.push_back({"encoder.mix_fc.weight", {c.in_channels, c.encoder_input_dim()}});
    p.push_back({"encoder.mix_fc.bias", {c.in_channels}});
    p.push_back({"unet.pre_conv.weight", {c.in_channels, c.in_channels}});
    p.push_back({"unet.pre_conv.bias", {c.in_channels}});
    for (int l = 0; l < nb; ++l) {
      int in = n[static_cast<size_t>(l)];
      for (int b = 0; b < c.num_res_blocks; ++b) {
        res_block(p, c, "unet.encoders.Enc" + std::to_string(l) + "-Block" + std::to_string(b), in, n[static_cast<size_t>(l) + 1], true);
        in = n[static_cast<size_t>(l) + 1];
      }
    }
    res_block(p, c, "unet.pre_kl_bottleneck.pre_kl_bottleneck_0", top, top, false);
    res_block(p, c, "unet.pre_kl_bottleneck.pre_kl_bottleneck_1", top, top, false);
    p.push_back({"unet.pre_kl_bottleneck.pre_kl_bottleneck_gn.module.weight", {top}});
    p.push_back({"unet.pre_kl_bottleneck.pre_kl_bottleneck_gn.module.bias", {top}});
    p.push_back({"unet.pre_kl_bottleneck.pre_kl_bottleneck_2.module.weight", {2 * latent, top, 3, 3, 3}});
    p.push_back({"unet.pre_kl_bottleneck.pre_kl_bottleneck_2.module.bias", {2 * latent}});
  }
  if (part != VaePart::Encoder) {
    res_block(p, c, "unet.post_kl_bottleneck.post_kl_bottleneck_0", latent, top, false);
    res_block(p, c, "unet.post_kl_bottleneck.post_kl_bottleneck_1", top, top, false);
    for (int idx = -2; idx >= -nb; --idx) {  // decoders: Dec-2 .. Dec-nb
      const int in = n[static_cast<size_t>(static_cast<int>(n.size()) + idx + 1)];
      const int out = n[static_cast<size_t>(static_cast<int>(n.size()) + idx)];
      int block_in = in;
      for (int b = 0; b <= c.num_res_blocks; ++b) {
        res_block(p, c, "unet.decoders.Dec" + std::to_string(idx) + "." + std::to_string(b), block_in, out, false);
        block_in = out;
      }
    }
    for (int idx = -1; idx >= -nb; --idx)
      head(p, c, "unet.struct_convs.Struct" + std::to_string(idx), n[static_cast<size_t>(static_cast<int>(n.size()) + idx)], 2);
    head(p, c, "unet.semantic_head", n[1], c.num_semantic_classes);
  }
  return p;
}

}  // namespace icube::nn
