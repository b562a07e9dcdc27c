// `icube nn info` (tools/cmd_nn.cpp): lists a weight file's tensors and
// totals per prefix; a truncated file and, with --check-finite, a NaN are
// one-line errors naming the file and the tensor, with a non-zero exit.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "nn/safetensors.h"
#include "scene/atomic_file.h"

#include <cmath>
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
