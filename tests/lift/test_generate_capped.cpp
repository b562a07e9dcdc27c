// `icube generate` on the demo town at its default 832x480 camera with every storage binding
// capped at 1 MiB (ICUBE_MAX_STORAGE_BINDING; lavapipe's is 128 MiB) writes the same package,
// byte for byte, as without the cap: the ray caster's hits in windows of rays and its world
// through the hash-table pipeline (the 5.3 MB occupancy index does not fit), the appearance
// renderer's outputs in pixel windows, the lifted 1.8 M Gaussians splatted in depth slices and
// their 6.4 MB images in bands of tile rows, the radix sorts in windows.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/package_check.h"

#include <filesystem>
#include <string>

using namespace icube;
namespace fs = std::filesystem;

TEST_CASE("cli: icube generate under 1 MiB storage bindings writes the same package bytes as without the cap" *
          doctest::test_suite("slow-gpu")) {
  test::TempDir dir("generate-capped");
  const std::string scene = (dir.path / "scene.json").string();
  REQUIRE(test::run_icube("world demo-scene -o '" + scene + "'", dir.path).code == 0);
  const std::string icube = test::icube_binary().string();
  auto run = [&](const std::string& env, const fs::path& pkg) {
    return test::run_shell("cd '" + dir.path.string() + "' && " + env + " " + icube + " generate '" + scene +
                           "' --frames ::20 -o '" + pkg.string() + "' 2>&1");
  };
  const fs::path whole = dir.path / "whole", capped = dir.path / "capped";
  const auto [code, text] = run("", whole);
  INFO(text);
  REQUIRE(code == 0);
  const auto [capped_code, capped_text] = run("ICUBE_MAX_STORAGE_BINDING=1M", capped);
  INFO(capped_text);
  REQUIRE(capped_code == 0);
  CHECK(scene::check_package(capped.string()).complete);
  CHECK(scene::read_file((capped / "manifest.json").string()) == scene::read_file((whole / "manifest.json").string()));
  // A cap the environment gets wrong is named.
  const auto [bad_code, bad_text] = run("ICUBE_MAX_STORAGE_BINDING=1X", dir.path / "bad");
  CHECK(bad_code != 0);
  CHECK(bad_text.find("ICUBE_MAX_STORAGE_BINDING=1X: expected a positive byte count") != std::string::npos);
}
