// `icube generate` end to end on the demo town at a small camera: the package
// (world, buffers, frames, Gaussians, manifest) with every file's SHA-256 in
// the manifest (the same bytes from a second run: test_generate_repeat.cpp), the Gaussians loadable by the
// splat scene reader, and bad input refused with nothing written.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "scene/atomic_file.h"
#include "scene/package_check.h"
#include "scene/sha256.h"
#include "splat/splat_scene.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

using namespace icube;
namespace fs = std::filesystem;

TEST_CASE("cli: icube generate writes a complete package, the same bytes twice, and refuses bad input" *
          doctest::test_suite("slow-gpu")) {
  test::TempDir dir("generate");
  const std::string scene = (dir.path / "scene.json").string();
  REQUIRE(test::run_icube("world demo-scene -o '" + scene + "'", dir.path).code == 0);
  const std::string args = "generate '" + scene + "' --camera 180,180,104,60,208,120 --frames 20:32:2 --no-video ";
  const fs::path pkg = dir.path / "pkg";
  const test::CliRun r = test::run_icube(args + "-o '" + pkg.string() + "'", dir.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  CHECK(r.output.find("stage") != std::string::npos);  // the summary table
  for (const char* f : {"world.icw", "manifest.json", "buffers/contact_sheet.png", "frames/frames_meta.json",
                        "gaussians/gaussians_static.ply", "gaussians/sky.png", "gaussians/scene.json",
                        "gaussians/lift_report.json", "gaussians/eval.png", "preview/flythrough.png"})
    CHECK_MESSAGE(fs::is_regular_file(pkg / f), f);
  const auto m = nlohmann::json::parse(scene::read_file((pkg / "manifest.json").string()));
  CHECK(m["format"] == "icube-package");
  CHECK(m["version"] == 1);
  CHECK(m["frames"] == 6);
  CHECK(m["stages"].size() == 5);
  CHECK(m["inputs"]["scene_sha256"] == scene::sha256_file(scene));
  // Every file but the manifest is listed with its hash, and nothing else is.
  size_t listed = 0;
  for (const auto& e : fs::recursive_directory_iterator(pkg)) {
    if (!e.is_regular_file() || e.path().filename() == "manifest.json") continue;
    const std::string rel = fs::relative(e.path(), pkg).generic_string();
    REQUIRE_MESSAGE(m["files"].contains(rel), rel);
    CHECK(m["files"][rel] == scene::sha256_file(e.path().string()));
    ++listed;
  }
  CHECK(listed == m["files"].size());
  const splat::SplatScene sc = splat::read_splat_scene((pkg / "gaussians" / "scene.json").string());
  CHECK(sc.static_set.size() > 1000);
  // Same inputs and seed, the same package bytes: tests/lift/test_generate_repeat.cpp (with videos).

  // --frames-from: frames made elsewhere from this job's buffers (here the package's own, as a video model's
  // output would come) are imported instead of rendered, with the buffers' poses; the lift runs on them.
  // Sky masks segmented from them (here the package's own masks: a segmentation that agrees with the
  // buffers, so the pixel branch finds next to no mid-ground).
  const fs::path video_out = dir.path / "video_out", pkg3 = dir.path / "pkg3", short_out = dir.path / "short";
  const fs::path masks = dir.path / "masks";
  fs::create_directories(video_out);
  fs::create_directories(short_out);
  fs::copy(pkg / "frames" / "sky_mask", masks);
  for (const auto& e : fs::directory_iterator(pkg / "frames" / "rgb")) {
    fs::copy_file(e.path(), video_out / e.path().filename());
    if (e.path().filename() != "000005.png") fs::copy_file(e.path(), short_out / e.path().filename());
  }
  const test::CliRun imp = test::run_icube(args + "--frames-from '" + video_out.string() + "' --sky-masks '" +
                                               masks.string() + "' -o '" + pkg3.string() + "'",
                                           dir.path);
  INFO(imp.output);
  REQUIRE(imp.code == 0);
  CHECK(imp.output.find("imported 6 frames") != std::string::npos);
  const auto m3 = nlohmann::json::parse(scene::read_file((pkg3 / "frames" / "frames_meta.json").string()));
  CHECK(m3["source"] == "import");
  CHECK(m3["poses"].size() == 6);
  CHECK(m3["sky_mask"] == "segmentation");
  const auto man3 = nlohmann::json::parse(scene::read_file((pkg3 / "manifest.json").string()));
  CHECK(man3["inputs"].contains("frames_from_sha256"));
  CHECK(man3["inputs"].contains("sky_masks_sha256"));
  const auto rep3 = nlohmann::json::parse(scene::read_file((pkg3 / "gaussians" / "lift_report.json").string()));
  INFO("mid-ground pixels " << rep3["midground_pixels"].dump());
  CHECK(rep3["midground_pixels"]["total"].get<size_t>() * 200 <= size_t(m3["width"]) * size_t(m3["height"]));
  const splat::SplatScene sc3 = splat::read_splat_scene((pkg3 / "gaussians" / "scene.json").string());
  const double ratio = double(sc3.static_set.size()) / double(sc.static_set.size());
  INFO("static Gaussians from the imported frames " << sc3.static_set.size() << ", rendered " << sc.static_set.size());
  CHECK(ratio > 0.95);
  CHECK(ratio < 1.05);
  // Frames that do not match the buffers (one short): refused, nothing written.
  const fs::path pkg4 = dir.path / "pkg4";
  const test::CliRun bad =
      test::run_icube(args + "--frames-from '" + short_out.string() + "' -o '" + pkg4.string() + "'", dir.path);
  CHECK(bad.code != 0);
  CHECK(bad.output.find("short") != std::string::npos);
  CHECK_FALSE(fs::exists(pkg4));
  const test::CliRun lone = test::run_icube(args + "--sky-masks '" + masks.string() + "' -o '" + pkg4.string() + "'", dir.path);
  CHECK(lone.code != 0);
  CHECK(lone.output.find("--sky-masks goes with --frames-from") != std::string::npos);
  CHECK_FALSE(fs::exists(pkg4));
  // A mask short: refused before any stage, nothing written.
  const fs::path short_masks = dir.path / "short_masks";
  fs::copy(masks, short_masks);
  fs::remove(short_masks / "000005.png");
  const test::CliRun few = test::run_icube(args + "--frames-from '" + video_out.string() + "' --sky-masks '" +
                                               short_masks.string() + "' -o '" + pkg4.string() + "'",
                                           dir.path);
  CHECK(few.code != 0);
  CHECK(few.output.find("5 sky masks, but the camera path has 6 frames") != std::string::npos);
  CHECK(few.output.find("[world]") == std::string::npos);  // no stage ran
  CHECK_FALSE(fs::exists(pkg4));

  // Bad input: a missing scene, a corrupt --world. One-line errors, no package, no staging left.
  // A staging folder left by a killed run (no process holds its lock) is removed by a run without --resume.
  const fs::path none = dir.path / "none", stale = dir.path / ".pkg.partial";
  fs::create_directories(stale / "frames");
  REQUIRE(test::run_icube(args + "-o '" + pkg.string() + "'", dir.path).code == 0);
  CHECK_FALSE(fs::exists(stale));
  test::CliRun e = test::run_icube("generate '" + (dir.path / "missing.json").string() + "' -o '" + none.string() + "'",
                                   dir.path);
  CHECK(e.code != 0);
  CHECK(e.output.find("missing.json") != std::string::npos);
  const std::string bad_world = (dir.path / "bad.icw").string();
  scene::write_file_atomic(bad_world, "not a world");
  e = test::run_icube(args + "--world '" + bad_world + "' -o '" + none.string() + "'", dir.path);
  CHECK(e.code != 0);
  CHECK(e.output.find("bad.icw") != std::string::npos);
  CHECK_FALSE(fs::exists(none));
  for (const auto& f : fs::directory_iterator(dir.path))
    CHECK_MESSAGE(f.path().filename().string().find(".partial") == std::string::npos, f.path().string());
  CHECK_FALSE(fs::exists(dir.path / ".pkg.lock"));
  // The package's manifest verifies; a changed byte does not.
  CHECK(scene::check_package(pkg.string()).complete);
  scene::write_file_atomic((pkg / "gaussians" / "sky.png").string(), "changed");
  CHECK(scene::check_package(pkg.string()).problem.find("sky.png: SHA-256 differs") != std::string::npos);
}
