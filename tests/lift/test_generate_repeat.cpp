// `icube generate` with its videos (buffers' mp4s and the preview's flythrough.mp4) gives the same
// bytes every time: two runs (the second next to a CPU-bound process, as x264's rate control
// used to make the preview differ under load) and a run killed right after each stage and
// finished with --resume all write the same manifest (the SHA-256 of every file). The busy core
// lives exactly as long as the loaded run (it used to spin on for 120 s, under the kills too).
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/package_check.h"

#include <filesystem>
#include <string>

using namespace icube;
namespace fs = std::filesystem;

TEST_CASE("cli: icube generate with videos: two runs and every killed-and-resumed run give the same manifest" *
          doctest::test_suite("slow-gpu")) {
  test::TempDir dir("generate-repeat");
  const std::string scene = (dir.path / "scene.json").string();
  REQUIRE(test::run_icube("world demo-scene -o '" + scene + "'", dir.path).code == 0);
  const std::string icube = test::icube_binary().string();
  const std::string args = " generate '" + scene + "' --camera 180,180,104,60,208,120 --frames 20:40:2 ";
  auto run = [&](const std::string& env, const fs::path& pkg, const std::string& extra = "") {
    return test::run_shell("cd '" + dir.path.string() + "' && " + env + " " + icube + args + extra + "-o '" +
                           pkg.string() + "'");
  };
  const fs::path first = dir.path / "first";
  const auto [code, text] = run("", first);
  INFO(text);
  REQUIRE(code == 0);
  REQUIRE(fs::is_regular_file(first / "preview" / "flythrough.mp4"));
  REQUIRE(fs::is_regular_file(first / "buffers" / "clip" / "semantic_buffer_video_480p_front.mp4"));
  const std::string want = scene::read_file((first / "manifest.json").string());

  // Again, with a busy core beside it for the whole run (and not after it).
  const fs::path loaded = dir.path / "loaded";
  REQUIRE(test::run_shell("cd '" + dir.path.string() + "' && { sh -c 'while :; do :; done' & busy=$!; " + icube + args +
                          "-o '" + loaded.string() + "'; rc=$?; kill $busy; exit $rc; }")
              .first == 0);
  CHECK(scene::read_file((loaded / "manifest.json").string()) == want);

  for (const char* stage : {"world", "buffers", "frames", "lift", "preview"}) {
    CAPTURE(stage);
    const fs::path pkg = dir.path / (std::string("killed-") + stage);
    CHECK(run(std::string("ICUBE_GENERATE_KILL_AFTER=") + stage, pkg).first != 0);
    CHECK_FALSE(fs::exists(pkg));
    const auto [rc, out] = run("", pkg, "--resume ");
    INFO(out);
    REQUIRE(rc == 0);
    CHECK(scene::check_package(pkg.string()).complete);
    CHECK(scene::read_file((pkg / "manifest.json").string()) == want);
  }
}
