// The CPU reference of InfiniCube's dense diffusion UNet
// (engine/nn/unet_reference.h) against the official PyTorch module's
// reference case (../shared/data/models/unet_small: output and every block's
// output, max |y - y_ref| / std(y_ref) <= 1e-4), the parameter list against the
// official state dict, weight binding with checkpoint prefixes, and
// configuration errors.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gpu_test_context.h"
#include "nn/unet_case_check.h"
#include "nn/safetensors.h"
#include "nn/unet_config.h"
#include "nn/timestep_embedding.h"
#include "nn/unet_reference.h"
#include "nn/weights.h"
#include "scene/atomic_file.h"
#include "scene/input_error.h"
#include "world/npy.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

using namespace icube;

namespace {

nn::UNetConfig tiny_config() {
  return nn::parse_unet_config(R"({"image_size": 8, "num_input_channels": 5, "out_channels": 3, "model_channels": 32,
    "num_res_blocks": 1, "attention_resolutions": [2], "channel_mult": [1, 2], "num_heads": 4,
    "use_scale_shift_norm": true, "resblock_updown": true, "transformer_depth": 2, "legacy": true,
    "middile_force_spatial_transformer": true, "middle_disable_first_sa": false, "dropout": 0.0})",
                               "tiny.json");
}

}  // namespace

TEST_CASE("unet reference: unet_small matches the official PyTorch module, output and every block") {
  const std::string dir = test::test_data_dir();
  if (dir.empty()) return;
  const std::string m = dir + "/models/unet_small/";
  const nn::UNetConfig cfg = nn::load_unet_config(m + "config.json");
  nn::UNetReference net(cfg);
  CHECK(net.parameters().size() == 395);
  CHECK(net.parameter_count() == 6982600);
  const nn::SafetensorsFile weights(m + "weights.safetensors");
  net.set_weights(nn::load_weights_cpu(weights, net.parameters(), {}));
  const test::UNetCaseResult r = test::check_unet_small_case(
      m, [&](const nn::CpuTensor& x, const std::vector<int64_t>& t, const nn::UNetReference::Capture& c) {
        return net.forward(x, t, c);
      });
  MESSAGE("unet_small: output max |y - y_ref| / std(y_ref) = " << r.output << " (bound 1e-4); worst of " << r.blocks
                                                                << " blocks " << r.worst_block);
}

TEST_CASE("unet reference: the released configuration's parameters and the preset") {
  const nn::UNetReference net(nn::load_unet_config("infinicube-diffusion"));
  // ~0.8 B parameters, ~115 M of them in the 12-block middle transformer (conventions §8.2).
  const uint64_t n = net.parameter_count();
  MESSAGE("released UNet: " << n << " parameters in " << net.parameters().size() << " tensors");
  CHECK(n > 700'000'000);
  CHECK(n < 900'000'000);
  uint64_t middle = 0;
  for (const nn::ParamSpec& p : net.parameters())
    if (p.name.rfind("middle_block.1.", 0) == 0) middle += static_cast<uint64_t>(nn::CpuTensor::count(p.shape));
  CHECK(middle > 100'000'000);
  CHECK(middle < 130'000'000);
  // Names as in the official state dict (reference manifest, when present).
  const std::string tsv = std::string(ICUBE_SOURCE_DIR) + "/../shared/reference/models/diffusion_unet.tsv";
  if (!std::filesystem::exists(tsv)) return;
  std::map<std::string, std::string> manifest;
  std::istringstream in(scene::read_file(tsv));
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("name\t", 0) == 0) continue;
    if (line.rfind("unet.", 0) == 0) line = line.substr(5);  // the checkpoint prefix
    const size_t tab = line.find('\t');
    if (tab == std::string::npos) continue;
    const size_t tab2 = line.find('\t', tab + 1);
    manifest[line.substr(0, tab)] = line.substr(tab + 1, tab2 == std::string::npos ? std::string::npos : tab2 - tab - 1);
  }
  size_t found = 0;
  for (const nn::ParamSpec& p : net.parameters()) {
    const auto it = manifest.find(p.name);
    if (it == manifest.end()) {
      FAIL_CHECK("not in the official manifest: " << p.name);
      continue;
    }
    ++found;
    std::string s = nn::CpuTensor(p.shape).shape_text();
    s.erase(std::remove(s.begin(), s.end(), ' '), s.end());
    std::string want = it->second;
    want.erase(std::remove_if(want.begin(), want.end(), [](char c) { return c == ' ' || c == '(' || c == ')'; }), want.end());
    s = s.substr(1, s.size() - 2);
    if (want.front() == '[') want = want.substr(1, want.size() - 2);
    CHECK_MESSAGE(s == want, p.name << ": ours " << s << ", manifest " << it->second);
  }
  CHECK(found == manifest.size());
  CHECK(net.parameters().size() == manifest.size());
}

TEST_CASE("unet reference: weights under checkpoint prefixes, EMA, and bad files") {
  const nn::UNetReference net(tiny_config());
  std::mt19937 rng(5);
  std::normal_distribution<float> nd(0.0f, 0.1f);
  std::vector<nn::TensorToWrite> live, ema, bare;
  for (const nn::ParamSpec& p : net.parameters()) {
    std::vector<float> v(static_cast<size_t>(nn::CpuTensor::count(p.shape)));
    for (float& f : v) f = nd(rng);
    bare.push_back(nn::f32_tensor(p.name, p.shape, v));
    live.push_back(nn::f32_tensor("unet." + p.name, p.shape, v));
    std::string flat = p.name;
    flat.erase(std::remove(flat.begin(), flat.end(), '.'), flat.end());
    for (float& f : v) f *= 2.0f;
    ema.push_back(nn::f32_tensor("unet_ema." + flat, p.shape, v));
  }
  std::vector<nn::TensorToWrite> ckpt = live;
  ckpt.insert(ckpt.end(), ema.begin(), ema.end());
  ckpt.push_back(nn::f32_tensor("vae.decoder.conv.weight", {2}, {1.f, 2.f}));
  ckpt.push_back(nn::f32_tensor("scale_factor", {}, {0.7f}));
  const nn::SafetensorsFile ck = nn::SafetensorsFile::from_bytes(nn::safetensors_bytes(ckpt), "ckpt.safetensors");
  const auto wl = nn::load_weights_cpu(ck, net.parameters(), {});
  nn::WeightOptions eo;
  eo.ema = true;
  const auto we = nn::load_weights_cpu(ck, net.parameters(), eo);
  const std::string first = net.parameters().front().name;
  CHECK(we.at(first).data[0] == 2.0f * wl.at(first).data[0]);
  const nn::SafetensorsFile bf = nn::SafetensorsFile::from_bytes(nn::safetensors_bytes(bare), "bare.safetensors");
  CHECK(nn::load_weights_cpu(bf, net.parameters(), {}).at(first).data == wl.at(first).data);
  CHECK_THROWS_WITH_AS(nn::load_weights_cpu(bf, net.parameters(), eo), doctest::Contains("bare.safetensors: --ema: the file has no EMA copy"),
                       scene::InputError);
  // Missing, wrong shape, unexpected.
  std::vector<nn::TensorToWrite> missing(bare.begin() + 1, bare.end());
  CHECK_THROWS_WITH_AS(
      nn::load_weights_cpu(nn::SafetensorsFile::from_bytes(nn::safetensors_bytes(missing), "m.safetensors"), net.parameters(), {}),
      doctest::Contains(std::string("m.safetensors: tensor '" + first + "': missing (the model needs").c_str()), scene::InputError);
  std::vector<nn::TensorToWrite> wrong = bare;
  wrong[0] = nn::f32_tensor(wrong[0].name, {static_cast<int64_t>(wrong[0].bytes.size() / 4)},
                            std::vector<float>(wrong[0].bytes.size() / 4, 0.f));
  CHECK_THROWS_WITH_AS(
      nn::load_weights_cpu(nn::SafetensorsFile::from_bytes(nn::safetensors_bytes(wrong), "s.safetensors"), net.parameters(), {}),
      doctest::Contains(std::string("s.safetensors: tensor '" + first + "': shape [").c_str()), scene::InputError);
  std::vector<nn::TensorToWrite> extra = bare;
  extra.push_back(nn::f32_tensor("input_blocks.99.0.weight", {1}, {0.f}));
  CHECK_THROWS_WITH_AS(
      nn::load_weights_cpu(nn::SafetensorsFile::from_bytes(nn::safetensors_bytes(extra), "x.safetensors"), net.parameters(), {}),
      doctest::Contains("x.safetensors: tensor 'input_blocks.99.0.weight': unexpected"), scene::InputError);
  std::vector<nn::TensorToWrite> nan = bare;
  nan[3] = nn::f32_tensor(nan[3].name, net.parameters()[3].shape,
                          std::vector<float>(nan[3].bytes.size() / 4, std::nanf("")));
  const nn::SafetensorsFile nf = nn::SafetensorsFile::from_bytes(nn::safetensors_bytes(nan), "n.safetensors");
  nn::WeightOptions fo;
  fo.check_finite = true;
  CHECK_THROWS_WITH_AS(nn::load_weights_cpu(nf, net.parameters(), fo),
                       doctest::Contains(std::string("n.safetensors: tensor '" + net.parameters()[3].name + "': element 0 is not finite").c_str()),
                       scene::InputError);
}

TEST_CASE("unet reference: a batch of two is two batches of one; non-cubic grids; the self-attention middle") {
  nn::UNetReference net(tiny_config());
  std::mt19937 rng(9);
  std::normal_distribution<float> nd(0.0f, 0.2f);
  std::map<std::string, nn::CpuTensor> w;
  for (const nn::ParamSpec& p : net.parameters()) {
    nn::CpuTensor t(p.shape);
    for (float& f : t.data) f = nd(rng);
    w.emplace(p.name, std::move(t));
  }
  net.set_weights(w);
  nn::CpuTensor x({2, 5, 4, 2, 6});
  for (float& f : x.data) f = nd(rng) * 5.0f;
  const nn::CpuTensor y = net.forward(x, {3, 977});
  CHECK(y.shape == std::vector<int64_t>{2, 3, 4, 2, 6});
  for (int b = 0; b < 2; ++b) {
    nn::CpuTensor xb({1, 5, 4, 2, 6}, std::vector<float>(x.data.begin() + b * 240, x.data.begin() + (b + 1) * 240));
    const nn::CpuTensor yb = net.forward(xb, {b == 0 ? 3 : 977});
    CHECK(std::equal(yb.data.begin(), yb.data.end(), y.data.begin() + b * 144));
  }
  bool finite = true;
  for (float f : y.data) finite = finite && std::isfinite(f);
  CHECK(finite);
  CHECK_THROWS_AS(net.forward(x, {3}), std::invalid_argument);
}

TEST_CASE("unet config: official keyword arguments, and clear errors for the rest") {
  const nn::UNetConfig c = tiny_config();
  CHECK(c.in_channels == 5);
  CHECK(c.outputs() == 3);
  CHECK(c.transformer_depth == 2);
  auto error = [](const std::string& text) {
    try {
      nn::parse_unet_config(text, "c.json");
    } catch (const scene::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string base = R"("image_size": 8, "num_input_channels": 5, "model_channels": 32, "num_res_blocks": 1, "attention_resolutions": [2])";
  CHECK(error("{" + base + R"(, "dims": 2})").find("c.json: dims: 2: only the dense 3-D UNet") != std::string::npos);
  CHECK(error("{" + base + R"(, "num_classes": 10})").find("num_classes: class conditioning is not implemented") != std::string::npos);
  CHECK(error("{" + base + R"(, "context_dim": 768})").find("context_dim") != std::string::npos);
  CHECK(error("{" + base + R"(, "use_spatial_transformer": true})").find("use_spatial_transformer") != std::string::npos);
  CHECK(error("{" + base + R"(, "warp": 1})").find("c.json: warp: is not a UNetModel argument") != std::string::npos);
  CHECK(error("{" + base + R"(, "channel_mult": [1, 1.5]})").find("channel_mult: is not an integer") != std::string::npos);
  CHECK(error("{" + base + R"(, "model_channels": 48})").find("not a multiple of GroupNorm's 32 groups") != std::string::npos);
  CHECK(error(R"({"image_size": 8})").find("needs image_size, num_input_channels") != std::string::npos);
  CHECK(error("[1]").find("is not a JSON object") != std::string::npos);
  CHECK(error("{").find("not valid JSON") != std::string::npos);
  CHECK(error("{" + base + R"(, "dropout": 0.1, "use_checkpoint": true, "use_fp16": false})") == "no error");
}

TEST_CASE("unet reference: the sinusoidal timestep embedding is [cos | sin], frequency 1 first") {
  const nn::CpuTensor e = nn::cpu::timestep_embedding({0, 7}, 6);
  CHECK(e.data[0] == 1.0f);   // cos(0)
  CHECK(e.data[3] == 0.0f);   // sin(0)
  CHECK(e.data[6] == doctest::Approx(std::cos(7.0)));
  CHECK(e.data[9] == doctest::Approx(std::sin(7.0)));
  CHECK(e.data[11] == doctest::Approx(std::sin(7.0 * std::exp(-std::log(10000.0) * 2.0 / 3.0))).epsilon(1e-5));
}
