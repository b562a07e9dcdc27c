// Stage 3 dynamic objects (engine/lift/dynamic_lift.h): samples of one object
// seen at two poses meet in its object frame; the demo town's moving cars
// lifted by `icube lift --scene` into object-frame PLYs with tracks, placed at
// a held-out frame where the frame's instance buffer shows them.
#include <doctest/doctest.h>

#include "cli_test_util.h"
#include "lift_demo_frames.h"
#include "object_coverage.h"
#include "lift/dynamic_lift.h"
#include "lift/lift_frames.h"
#include "scene/atomic_file.h"
#include "scene/png_read.h"
#include "splat/rasterizer_cpu.h"
#include "splat/splat_scene.h"

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>

using namespace icube;
namespace fs = std::filesystem;

TEST_CASE("lift dynamic: one object point seen at two poses is one Gaussian in the object frame") {
  // Pose A: at (10, 0, 0), heading 0. Pose B: at (-5, 20, 1), heading 90 degrees.
  const glm::dmat4 a = glm::translate(glm::dmat4(1.0), glm::dvec3(10.0, 0.0, 0.0));
  const glm::dmat4 b = glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(-5.0, 20.0, 1.0)), 0.5 * M_PI,
                                   glm::dvec3(0.0, 0.0, 1.0));
  const glm::dvec3 p_obj(1.23, -0.41, 0.77);  // a point on the car, object frame
  lift::DynamicLiftOptions o;
  lift::DynamicLiftAccumulator acc(o);
  acc.add(10001, glm::dvec3(a * glm::dvec4(p_obj, 1.0)), glm::inverse(a), 100, 0, 0);
  acc.add(10001, glm::dvec3(b * glm::dvec4(p_obj, 1.0)), glm::inverse(b), 200, 50, 0);
  acc.add(10002, glm::dvec3(3.0, 3.0, 3.0), glm::dmat4(1.0), 0, 0, 255);
  CHECK(acc.samples() == 3);
  const auto objs = acc.emit();
  REQUIRE(objs.size() == 2);
  const splat::GaussianCloud& c = objs.at(10001);
  REQUIRE(c.size() == 1);
  CHECK(glm::length(c.positions[0] - p_obj) < 1e-9);
  CHECK(double(c.sh[0]) * splat::kShC0 + 0.5 == doctest::Approx(150.0 / 255.0).epsilon(1e-5));
  CHECK(c.scales[0].x == doctest::Approx(double(o.sigma_cells) * o.cell));
  CHECK(c.opacities[0] == doctest::Approx(o.opacity));
  // Placed back at pose B the Gaussian is where the car's point is in the world.
  splat::GaussianCloud placed;
  splat::append_placed(placed, c, b);
  CHECK(glm::length(placed.positions[0] - glm::dvec3(b * glm::dvec4(p_obj, 1.0))) < 1e-9);
}

TEST_CASE("cli: icube lift --scene lifts the demo town's moving cars into object frames with tracks" *
          doctest::test_suite("slow-gpu")) {
  const test::LiftDemoFrames& demo = test::lift_demo_frames();
  const test::TempDir& dir = demo.dir;
  const std::string &scene = demo.scene, &world = demo.world;
  const fs::path &frames = demo.frames, out = dir.path / "lifted-dynamic";
  const test::CliRun r = test::run_icube(
      "lift '" + world + "' '" + frames.string() + "' --scene '" + scene + "' -o '" + out.string() + "'", dir.path);
  INFO(r.output);
  REQUIRE(r.code == 0);
  const auto rep = nlohmann::json::parse(scene::read_file((out / "lift_report.json").string()));
  MESSAGE("objects " << rep["objects"].dump() << "; held-out " << rep["held_out"].dump());
  REQUIRE(rep["objects"].size() >= 1);
  const splat::SplatScene sc = splat::read_splat_scene((out / "scene.json").string());
  REQUIRE(sc.objects.size() == rep["objects"].size());
  CHECK(sc.frames() == 317);  // every scene state of the demo drive (the frames carry scene times)

  // At a held-out frame, the objects alone cover the pixels the frame's instance buffer gives to
  // dynamic cars, and few others.
  const render::FramesMeta meta = render::read_frames_meta(frames.string());
  const size_t f = 3;
  const test::ObjectCoverage c = test::object_coverage(sc, frames.string(), meta, f);
  REQUIRE(c.gaussians > 0);
  const size_t dyn = c.dynamic, covered = c.covered, fringe = c.fringe, beyond = c.beyond;
  MESSAGE("frame " << f << ": " << dyn << " dynamic pixels, " << covered << " covered by the placed objects; object "
                   << "pixels outside the mask: " << fringe << " within 1 px of it, " << beyond << " beyond");
  REQUIRE(dyn > 50);
  CHECK(double(covered) >= 0.8 * double(dyn));
  CHECK(double(beyond) <= 0.1 * double(dyn));
}
