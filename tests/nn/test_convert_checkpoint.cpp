// tools/convert_checkpoint.py on small synthetic checkpoints laid out as
// InfiniCube's Lightning diffusion checkpoint (tests/nn/make_synthetic_checkpoint.py
// builds them with PyTorch from seeded random weights of a reduced UNet): the
// EMA or live copy under bare official names that the engine loads against the
// converted config, scale_factor in the metadata and the config, the VAE's
// tensors, the config read off the weights, and bad checkpoints refused with
// one line and no output. The converter needs numpy only; making the checkpoints
// needs Debian's python3-torch (tools/install-deps.sh --test).
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "nn/latent_scale.h"
#include "nn/random_weights.h"
#include "nn/safetensors.h"
#include "nn/unet_config.h"
#include "nn/vae_config.h"
#include "nn/vae_weights.h"
#include "nn/unet_reference.h"
#include "nn/weights.h"
#include "scene/atomic_file.h"

#include <algorithm>
#include <cstring>
#include <random>
#include <string>

using namespace icube;

namespace {

using test::run_shell;

const char* kTinyKwargs = R"({"unet_kwargs": {"image_size": 8, "num_input_channels": 5, "out_channels": 3,
  "model_channels": 32, "num_res_blocks": 1, "attention_resolutions": [2], "channel_mult": [1, 2], "num_heads": 4,
  "use_scale_shift_norm": true, "resblock_updown": true, "transformer_depth": 2, "legacy": true,
  "middile_force_spatial_transformer": true, "middle_disable_first_sa": false, "dropout": 0.0}})";

// A reduced structure VAE of the official structure (two levels, 16 feature maps, a 4^3 neck).
const char* kTinyVae = R"({"vae_kwargs": {"in_channels": 32, "num_blocks": 2, "f_maps": 16, "cut_ratio": 4,
  "neck_dense_type": "HAND_CRAFTED", "neck_bound": [4, 4, 4], "num_res_blocks": 1, "use_residual": true,
  "order": "gcs", "is_add_dec": true, "use_attention": false, "use_checkpoint": false, "pooling_level": [1],
  "with_semantic_branch": true, "with_normal_branch": false}})";

void check_same_vae(const nn::VaeConfig& a, const nn::VaeConfig& b, bool with_hparams) {
  CHECK(a.in_channels == b.in_channels);
  CHECK(a.num_blocks == b.num_blocks);
  CHECK(a.f_maps == b.f_maps);
  CHECK(a.cut_ratio == b.cut_ratio);
  CHECK(a.num_res_blocks == b.num_res_blocks);
  CHECK(a.order == b.order);
  CHECK(a.num_semantic == b.num_semantic);
  CHECK(a.dim_semantic == b.dim_semantic);
  if (with_hparams) {  // what the weights cannot tell
    CHECK(a.neck_bound == b.neck_bound);
    CHECK(a.pooling_level == b.pooling_level);
  }
}

float bf16_round(float f) {  // round to nearest even, as torch's .to(bfloat16)
  uint32_t u;
  std::memcpy(&u, &f, 4);
  u = (u + 0x7fffu + ((u >> 16) & 1u)) & 0xffff0000u;
  std::memcpy(&f, &u, 4);
  return f;
}

}  // namespace

TEST_CASE("convert_checkpoint: Lightning diffusion checkpoints to safetensors + config the engine loads") {
  const std::string py = test::python_with("torch, numpy");
  if (py.empty()) {
    const char* req = std::getenv("ICUBE_REQUIRE_DATA");
    if (req && std::string(req) == "1") FAIL("python3 with torch is missing (tools/install-deps.sh --test installs python3-torch)");
    MESSAGE("skipped: no python3 with torch (apt install python3-torch)");
    return;
  }
  const std::string src = ICUBE_SOURCE_DIR;
  const std::string make = py + " " + src + "/tests/nn/make_synthetic_checkpoint.py ";
  const std::string convert = py + " " + src + "/tools/convert_checkpoint.py ";
  test::TempDir tmp("convert-ckpt");
  const std::string dir = tmp.path.string();
  scene::write_file_atomic(dir + "/kwargs.json", kTinyKwargs);
  const nn::UNetConfig tiny = nn::load_unet_config(dir + "/kwargs.json");
  const nn::UNetReference net(tiny);
  std::mt19937 rng(17);
  std::normal_distribution<float> nd(0.0f, 0.1f);
  std::vector<nn::TensorToWrite> bare;
  std::map<std::string, std::vector<float>> original;
  for (const nn::ParamSpec& p : net.parameters()) {
    std::vector<float> v(static_cast<size_t>(nn::CpuTensor::count(p.shape)));
    for (float& f : v) f = nd(rng);
    bare.push_back(nn::f32_tensor(p.name, p.shape, v));
    original[p.name] = v;
  }
  nn::write_safetensors(dir + "/bare.safetensors", bare);
  scene::write_file_atomic(dir + "/vae_kwargs.json", kTinyVae);
  const nn::VaeConfig tiny_vae = nn::load_vae_config(dir + "/vae_kwargs.json");
  const std::map<std::string, nn::CpuTensor> vae_weights =
      nn::random_weights(nn::vae_param_specs(tiny_vae, nn::VaePart::All), 23);
  std::vector<nn::TensorToWrite> vae_bare;
  for (const auto& [name, t] : vae_weights) vae_bare.push_back(nn::f32_tensor(name, t.shape, t.data));
  nn::write_safetensors(dir + "/vae_bare.safetensors", vae_bare);
  const std::string first = net.parameters().front().name;
  // Makes DIR/NAME.ckpt from the bare weights, converts it into DIR/NAME; both must succeed.
  // Returns the converter's output.
  auto make_and_convert = [&](const std::string& name, const std::string& make_args, const std::string& convert_args) {
    const auto [mrc, mout] = run_shell(make + dir + "/bare.safetensors " + dir + "/" + name + ".ckpt " + make_args);
    REQUIRE_MESSAGE(mrc == 0, mout);
    const auto [rc, out] = run_shell(convert + dir + "/" + name + ".ckpt -o " + dir + "/" + name + " " + convert_args);
    REQUIRE_MESSAGE(rc == 0, out);
    return out;
  };

  SUBCASE("EMA copy by default, hyper_parameters as the config, scale_factor and the VAE") {
    const std::string out = make_and_convert("a", "--kwargs " + dir + "/kwargs.json --vae " + dir + "/vae_bare.safetensors", "");
    INFO(out);
    CHECK(out.find("(ema weights)") != std::string::npos);
    CHECK(out.find("left out: 3 entries (cond_stage_model, unet_ema)") != std::string::npos);
    const nn::UNetConfig c = nn::load_unet_config(dir + "/a/unet_config.json");
    CHECK(c.model_channels == tiny.model_channels);
    CHECK(c.channel_mult == tiny.channel_mult);
    CHECK(c.attention_resolutions == tiny.attention_resolutions);
    CHECK(c.num_heads == 4);
    CHECK(c.transformer_depth == 2);
    CHECK(c.middle_disable_first_sa == false);
    CHECK(c.in_channels == 5);
    CHECK(c.outputs() == 3);
    const nn::SafetensorsFile f(dir + "/a/unet.safetensors");
    CHECK(f.metadata().at("weights") == "ema");
    CHECK(std::stod(f.metadata().at("scale_factor")) == doctest::Approx(0.73).epsilon(1e-7));
    const auto w = nn::load_weights_cpu(f, net.parameters(), {});
    for (const nn::ParamSpec& p : net.parameters()) {
      std::vector<float> want = original[p.name];
      for (float& v : want) v *= 2.0f;  // the helper's EMA copy
      CHECK_MESSAGE(w.at(p.name).data == want, p.name);
    }
    CHECK(scene::read_file(dir + "/a/unet_config.json").find("\"scale_factor\": 0.73") != std::string::npos);
    // The VAE: its config read off the weights (the rest assumed from the released model and named), the
    // weights loading against it unchanged, the diffusion checkpoint's scale_factor in the metadata.
    CHECK(out.find("vae_config.json: in_channels 32, f_maps 16, num_blocks 2, num_res_blocks 1, cut_ratio 4; from the "
                   "released model (not in the checkpoint): neck_dense_type, neck_bound, pooling_level, order") != std::string::npos);
    const nn::VaeConfig vc = nn::load_vae_config(dir + "/a/vae_config.json");
    check_same_vae(vc, tiny_vae, false);
    const nn::SafetensorsFile vae(dir + "/a/vae.safetensors");
    const auto vw = nn::load_vae_weights_cpu(vae, vc, nn::VaePart::All, {});
    CHECK(vw.size() == vae_weights.size());
    CHECK(vw.at("unet.encoders.Enc1-Block0.conv2.Conv.weight").data ==
          nn::load_vae_weights_cpu(nn::SafetensorsFile(dir + "/vae_bare.safetensors"), tiny_vae, nn::VaePart::All, {})
              .at("unet.encoders.Enc1-Block0.conv2.Conv.weight")
              .data);
    const nn::LatentScale scale = nn::resolve_latent_scale(std::nullopt, vae);
    CHECK(scale.value == doctest::Approx(0.73).epsilon(1e-7));
    CHECK(scale.source == dir + "/a/vae.safetensors metadata");
    CHECK(nn::resolve_latent_scale(2.5, vae).value == 2.5);
  }

  SUBCASE("a standalone VAE checkpoint: vae.safetensors and vae_config.json from its weights and hyper_parameters") {
    const auto [mrc, mout] = run_shell(make + dir + "/vae_bare.safetensors " + dir + "/v.ckpt --standalone-vae --kwargs " + dir +
                                       "/vae_kwargs.json");
    REQUIRE_MESSAGE(mrc == 0, mout);
    const auto [rc, out] = run_shell(convert + dir + "/v.ckpt -o " + dir + "/v");
    INFO(out);
    REQUIRE(rc == 0);
    CHECK(out.find("left out: 1 entries (loss)") != std::string::npos);
    CHECK(out.find("from the released model") == std::string::npos);  // all from hyper_parameters
    CHECK_FALSE(std::filesystem::exists(dir + "/v/unet.safetensors"));
    check_same_vae(nn::load_vae_config(dir + "/v/vae_config.json"), tiny_vae, true);
    const nn::SafetensorsFile vae(dir + "/v/vae.safetensors");
    CHECK_FALSE(nn::resolve_latent_scale(std::nullopt, vae).given());
    CHECK(nn::load_vae_weights_cpu(vae, tiny_vae, nn::VaePart::All, {}).size() == vae_weights.size());
    // hyper_parameters that contradict the weights: refused.
    std::string wrong = kTinyVae;
    wrong.replace(wrong.find("\"f_maps\": 16"), 12, "\"f_maps\": 32");
    scene::write_file_atomic(dir + "/vae_wrong.json", wrong);
    REQUIRE(run_shell(make + dir + "/vae_bare.safetensors " + dir + "/vw.ckpt --standalone-vae --kwargs " + dir + "/vae_wrong.json")
                .first == 0);
    const auto [rc2, out2] = run_shell(convert + dir + "/vw.ckpt -o " + dir + "/vw");
    CHECK(rc2 == 1);
    CHECK(out2.find("vw.ckpt: hyper_parameters f_maps: says 32, the weights hold 16") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(dir + "/vw"));
  }

  SUBCASE("--weights live keeps bfloat16 as stored; hparams as a Namespace; foreign classes stay inert") {
    const std::string out = make_and_convert("b", "--bf16 --namespace-hparams --kwargs " + dir + "/kwargs.json --foreign-object",
                                             "--weights live");
    INFO(out);
    CHECK(out.find("pickled objects not built (inert placeholders): __main__.ForeignObject") != std::string::npos);
    CHECK(nn::load_unet_config(dir + "/b/unet_config.json").num_heads == 4);  // from the Namespace
    const nn::SafetensorsFile f(dir + "/b/unet.safetensors");
    CHECK(f.find(first)->dtype == nn::DType::BF16);
    const auto w = nn::load_weights_cpu(f, net.parameters(), {});
    std::vector<float> want = original[first];
    for (float& v : want) v = bf16_round(v);
    CHECK(w.at(first).data == want);
  }

  SUBCASE("no hyper_parameters and no EMA: the config is read off the weights, the rest named as assumed") {
    const std::string out = make_and_convert("c", "--no-ema", "");
    INFO(out);
    CHECK(out.find("(live weights)") != std::string::npos);
    CHECK(out.find("from the released model (not in the checkpoint): num_heads") != std::string::npos);
    const nn::UNetConfig c = nn::load_unet_config(dir + "/c/unet_config.json");
    CHECK(c.model_channels == 32);
    CHECK(c.num_res_blocks == 1);
    CHECK(c.channel_mult == std::vector<int>{1, 2});
    CHECK(c.attention_resolutions == std::vector<int>{2});
    CHECK(c.transformer_depth == 2);
    CHECK(c.middle_disable_first_sa == false);
    CHECK(c.use_scale_shift_norm);
    CHECK(c.num_heads == 8);  // not in the weights: the released model's
    const nn::UNetReference again(c);
    CHECK(again.parameters().size() == net.parameters().size());
    CHECK(nn::load_weights_cpu(nn::SafetensorsFile(dir + "/c/unet.safetensors"), again.parameters(), {}).at(first).data ==
          original[first]);
  }

  SUBCASE("bad checkpoints: one line naming the file and place, exit 1, no output") {
    struct Bad {
      std::string make_args, convert_args, message;
    };
    scene::write_file_atomic(dir + "/junk.ckpt", std::string("PK\x03\x04") + " this is no checkpoint");
    const std::string wrong_kwargs = std::string(kTinyKwargs).replace(std::string(kTinyKwargs).find("\"model_channels\": 32"),
                                                                       20, "\"model_channels\": 64");
    scene::write_file_atomic(dir + "/wrong.json", wrong_kwargs);
    const std::vector<Bad> cases = {
        {"--nan " + first, "--weights live", "tensor 'unet." + first + "': holds NaN or infinity"},
        {"--kwargs " + dir + "/wrong.json", "", "hyper_parameters network.diffuser.model_channels: says 64, the weights hold 32"},
        {"", "", "not a PyTorch checkpoint in torch.save's zip format"},
        {"--no-ema", "--weights ema", "--weights ema: the checkpoint has no EMA copy"},
    };
    for (size_t i = 0; i < cases.size(); ++i) {
      const Bad& b = cases[i];
      std::string ckpt = dir + "/junk.ckpt";
      if (!b.message.starts_with("not a PyTorch checkpoint")) {
        ckpt = dir + "/bad" + std::to_string(i) + ".ckpt";
        const auto [mrc, mout] = run_shell(make + dir + "/bare.safetensors " + ckpt + " " + b.make_args);
        INFO(mout);
        REQUIRE(mrc == 0);
      }
      const std::string outdir = dir + "/bad" + std::to_string(i);
      const auto [rc, out] = run_shell(convert + ckpt + " -o " + outdir + " " + b.convert_args);
      INFO(i, ": ", out);
      CHECK(rc == 1);
      CHECK(out.find(ckpt + ": ") != std::string::npos);
      CHECK(out.find(b.message) != std::string::npos);
      CHECK(std::count(out.begin(), out.end(), '\n') == 1);
      CHECK_FALSE(std::filesystem::exists(outdir));
    }
  }
}
