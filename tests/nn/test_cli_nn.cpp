// `icube nn info` and `icube nn forward` (tools/cmd_nn.cpp): listing a weight
// file's tensors and totals per prefix; a truncated file and, with
// --check-finite, a NaN are one-line errors naming the file and the tensor;
// the CPU-reference forward reproduces the unet_small reference case.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "gpu_test_context.h"
#include "kernels/nn/cpu_tensor.h"
#include "nn/safetensors.h"
#include "nn/unet_config.h"
#include "nn/unet_reference.h"
#include "scene/atomic_file.h"
#include "world/npy.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

using namespace icube;

TEST_CASE("cli: icube nn info lists tensors, totals and rejects bad weights") {
  test::TempDir tmp("cli-nn");
  const std::string good = (tmp.path / "good.safetensors").string();
  nn::write_safetensors(good, {nn::f32_tensor("unet.out.2.bias", {8}, std::vector<float>(8, 0.5f)),
                               nn::f32_tensor("unet_ema.out2bias", {8}, std::vector<float>(8, 0.5f)),
                               nn::f32_tensor("vae.decoder.w", {2, 3}, std::vector<float>(6, 1.0f))});
  test::CliRun r = test::run_icube("nn info '" + good + "' --check-finite", tmp.path);
  INFO(r.output);
  CHECK(r.code == 0);
  CHECK(r.output.find("3 tensors") != std::string::npos);
  CHECK(r.output.find("unet.out.2.bias") != std::string::npos);
  CHECK(r.output.find("[2, 3]") != std::string::npos);
  CHECK(r.output.find("unet_ema") != std::string::npos);
  CHECK(r.output.find("total: 22 parameters, all finite") != std::string::npos);

  const std::string nan = (tmp.path / "nan.safetensors").string();
  nn::write_safetensors(nan, {nn::f32_tensor("a", {3}, {1.0f, std::nanf(""), 2.0f})});
  r = test::run_icube("nn info '" + nan + "'", tmp.path);
  CHECK(r.code == 0);  // without --check-finite the values are not read
  r = test::run_icube("nn info '" + nan + "' --check-finite", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("nan.safetensors: tensor 'a': element 1 is not finite") != std::string::npos);

  const std::string bytes = scene::read_file(good);
  const std::string cut = (tmp.path / "cut.safetensors").string();
  scene::write_file_atomic(cut, bytes.substr(0, bytes.size() - 5));
  r = test::run_icube("nn info '" + cut + "'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("cut.safetensors: tensor '") != std::string::npos);
  CHECK(r.output.find("past the") != std::string::npos);
  CHECK(test::run_icube("nn info --help", tmp.path).code == 0);
}

TEST_CASE("cli: icube nn forward reproduces unet_small and dumps its layers; bad inputs leave no output") {
  const std::string m = test::test_data_file("models/unet_small/config.json");
  if (m.empty()) return;
  const std::string dir = std::filesystem::path(m).parent_path().string();
  test::TempDir tmp("cli-nn-forward");
  const std::string y = (tmp.path / "y.npy").string(), dump = (tmp.path / "layers.safetensors").string();
  const std::string common = "nn forward --model '" + dir + "/config.json' --weights '" + dir + "/weights.safetensors' ";
  test::CliRun r = test::run_icube(common + "--input '" + dir + "/case_1.x.npy' --timestep '" + dir +
                                       "/case_1.t.npy' --dump-layers '" + dump + "' -o '" + y + "'",
                                   tmp.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  const world::NpyArray got = world::read_npy(y), want = world::read_npy(dir + "/case_1.out.npy");
  REQUIRE(got.shape == want.shape);
  CHECK(nn::cpu::max_abs_over_std(got.values<float>(), want.values<float>()) <= 1e-4);
  const nn::SafetensorsFile layers(dump);
  CHECK(layers.tensors().size() == 27);
  CHECK(layers.find("middle_block") != nullptr);
  // The timestep file given as the input: a clear error, no output.
  const std::string y2 = (tmp.path / "y2.npy").string();
  r = test::run_icube(common + "--input '" + dir + "/case_1.t.npy' --timestep '" + dir + "/case_1.t.npy' -o '" + y2 + "'",
                      tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("case_1.t.npy: expected float32 [B, 16, X, Y, Z]") != std::string::npos);
  CHECK(!std::filesystem::exists(y2));
  // fp16 (weights and convolution operands): within fp16's error of the official output, and the report says so.
  const std::string y3 = (tmp.path / "y3.npy").string();
  r = test::run_icube(common + "--precision fp16 --input '" + dir + "/case_1.x.npy' --timestep '" + dir +
                          "/case_1.t.npy' -o '" + y3 + "'",
                      tmp.path);
  CHECK(r.code == 0);
  CHECK(r.output.find("fp16 (conv/linear) weights on the device; convolution operands (the norms' outputs) in fp16") !=
        std::string::npos);
  CHECK(nn::cpu::max_abs_over_std(world::read_npy(y3).values<float>(), want.values<float>()) <= 1e-2);
  // fp16 weights alone (fp32 operands): within the same bound, and written as well.
  const std::string y4 = (tmp.path / "y4.npy").string();
  r = test::run_icube(common + "--precision fp16-weights --input '" + dir + "/case_1.x.npy' --timestep '" + dir +
                          "/case_1.t.npy' -o '" + y4 + "'",
                      tmp.path);
  CHECK(r.code == 0);
  CHECK(nn::cpu::max_abs_over_std(world::read_npy(y4).values<float>(), want.values<float>()) <= 1e-2);
  r = test::run_icube(common + "--backend cpu --precision fp16 --input '" + dir + "/case_1.x.npy' --timestep '" + dir +
                          "/case_1.t.npy' -o '" + y2 + "'",
                      tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("--precision fp16 runs on the GPU backend only") != std::string::npos);
  CHECK(!std::filesystem::exists(y2));
  // The released preset against the small weights: the first wrong shape is named.
  r = test::run_icube("nn info '" + dir + "/weights.safetensors' --model infinicube-diffusion", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("tensor 'time_embed.0.weight': shape [128, 32], the model needs [768, 192]") != std::string::npos);
}

TEST_CASE("cli: icube nn random-weights checks the model's size before allocating; the UNet states its grid rule") {
  test::TempDir tmp("cli-nn-random-size");
  // The released structure with a million channels: ~1e13 parameters, refused by name at once.
  const std::string cfg = (tmp.path / "huge.json").string();
  scene::write_file_atomic(cfg, R"({"unet_kwargs": {"image_size": 64, "num_input_channels": 16, "out_channels": 8,
    "model_channels": 1000000, "num_res_blocks": 1, "attention_resolutions": [], "channel_mult": [1, 1, 1, 1],
    "num_heads": 4, "use_scale_shift_norm": true, "resblock_updown": true, "legacy": true, "dropout": 0.0}})");
  const std::string out = (tmp.path / "w.safetensors").string();
  const test::CliRun r = test::run_icube("nn random-weights --model '" + cfg + "' -o '" + out + "'", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.output.find("huge.json: ") != std::string::npos);
  CHECK(r.output.find("parameters need") != std::string::npos);
  CHECK(r.output.find("reduce model_channels") != std::string::npos);
  CHECK(r.output.find("bad_alloc") == std::string::npos);
  CHECK(!std::filesystem::exists(out));
  // A grid that the model's downsampling does not divide: the rule and the nearest sizes.
  const nn::UNetConfig c = nn::load_unet_config("infinicube-diffusion-tiny");
  CHECK(c.grid_multiple() == 8);
  CHECK_NOTHROW(nn::check_unet_grid(c, 8, 16, 64));
  CHECK_THROWS_WITH(nn::check_unet_grid(c, 7, 8, 8),
                    doctest::Contains("input grid 7x8x8: axis X (7) must be a positive multiple of 8 (the model halves "
                                      "the grid 3 times, channel_mult has 4 levels); pad or crop it to 8"));
  CHECK_THROWS_WITH(nn::check_unet_grid(c, 8, 8, 12), doctest::Contains("axis Z (12) must be a positive multiple of 8"));
  CHECK_THROWS_WITH(nn::check_unet_grid(c, 8, 8, 12), doctest::Contains("pad or crop it to 8 or 16"));
  // Through the reference forward: the check comes before any layer.
  nn::UNetReference ref(c);
  CHECK_THROWS_WITH(ref.forward(nn::CpuTensor({1, 16, 7, 8, 8}), {10}), doctest::Contains("must be a positive multiple of 8"));
}
