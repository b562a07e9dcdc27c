// The main job in process (engine/pipeline/generate_package.h) on the demo
// town at a small camera: every stage runs in order and reports progress, the
// package is complete with every path of scene/package_layout.h; a run stopped
// after a stage keeps its staging folder, and --resume continues it to the same
// manifest (the same bytes as an uninterrupted run); a complete package is
// skipped. The command's own tests: tests/lift/test_generate*.cpp.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "pipeline/generate_package.h"
#include "scene/atomic_file.h"
#include "scene/package_check.h"
#include "scene/package_layout.h"
#include "scene/scene_json.h"
#include "world/demo_scene.h"

#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <string>

using namespace icube;
namespace fs = std::filesystem;

namespace {

struct StoppedAfter : std::runtime_error {
  using std::runtime_error::runtime_error;
};

pipeline::GenerateArgs small_job(const fs::path& scene, const fs::path& out) {
  pipeline::GenerateArgs a;
  a.path.scene = scene.string();
  a.path.camera = "180,180,104,60,208,120";
  a.path.frames = "20:32:2";
  a.no_video = true;
  a.output = out.string();
  return a;
}

}  // namespace

TEST_CASE("pipeline: generate_package runs every stage in process, stops and resumes to the same bytes" *
          doctest::test_suite("slow-gpu")) {
  test::TempDir dir("pipeline-generate");
  const fs::path scene = dir.path / "scene.json";
  scene::write_scene_json(world::make_demo_scene(), scene.string());
  scene::Diagnostics diag;

  // A whole run, its progress and notes recorded.
  pipeline::GenerateArgs a = small_job(scene, dir.path / "whole");
  std::map<std::string, size_t> last_done, totals;
  std::vector<std::string> lines, finished;
  a.progress = [&](const std::string& stage, const std::string&, size_t done, size_t total) {
    last_done[stage] = done;
    totals[stage] = total;
  };
  a.log = [&](const std::string& line) { lines.push_back(line); };
  a.on_stage_finished = [&](const std::string& stage) { finished.push_back(stage); };
  const pipeline::GenerateResult r = pipeline::generate_package(a, diag);
  CHECK(finished == pipeline::generate_stage_names());
  REQUIRE(r.stages.size() == 5);
  for (const pipeline::GenerateStage& s : r.stages) {
    CAPTURE(s.name);
    CHECK_FALSE(s.resumed);
    CHECK_FALSE(s.detail.empty());
    CHECK(last_done[s.name] == totals[s.name]);  // each stage's progress reached its end
    CHECK(totals[s.name] > 0);
  }
  CHECK(lines.size() == 5);  // one "[stage] seconds: detail" line each
  CHECK(scene::check_package(r.package.string()).complete);
  const scene::PackageLayout pkg(r.package);
  for (const fs::path& p : {pkg.manifest(), pkg.world(), pkg.scene(), pkg.trajectory(), pkg.contact_sheet(), pkg.splat_scene(),
                            pkg.sky(), pkg.lift_report()})
    CHECK_MESSAGE(fs::is_regular_file(p), p.string());
  for (const fs::path& p : {pkg.clip(), pkg.frames(), pkg.preview()}) CHECK_MESSAGE(fs::is_directory(p), p.string());

  // Stopped after the frames (an exception from the stage hook, as a failure in the next stage would be):
  // no package, the staging folder kept with three stages.
  pipeline::GenerateArgs b = small_job(scene, dir.path / "stopped");
  b.on_stage_finished = [](const std::string& stage) {
    if (stage == "frames") throw StoppedAfter("stopped after " + stage);
  };
  CHECK_THROWS_AS(pipeline::generate_package(b, diag), StoppedAfter);
  CHECK_FALSE(fs::exists(dir.path / "stopped"));
  CHECK(fs::is_directory(dir.path / ".stopped.partial"));
  // Resumed: the first three stages are not run again, and the package is the uninterrupted run's, byte for byte.
  b.on_stage_finished = {};
  b.resume = true;
  const pipeline::GenerateResult resumed = pipeline::generate_package(b, diag);
  CHECK(resumed.resumed_stages == 3);
  for (size_t i = 0; i < resumed.stages.size(); ++i) CHECK(resumed.stages[i].resumed == (i < 3));
  CHECK(scene::read_file(scene::PackageLayout(resumed.package).manifest().string()) == scene::read_file(pkg.manifest().string()));
  CHECK_FALSE(fs::exists(dir.path / ".stopped.partial"));
  // Complete and made from the same inputs: nothing to do.
  const pipeline::GenerateResult again = pipeline::generate_package(b, diag);
  CHECK(again.skipped);
  CHECK(again.stages.empty());
}
